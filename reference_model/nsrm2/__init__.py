"""NSRM v2 (``nsrm-v2``), the neuro-symbolic reference model rebuilt on the shared program
parts (:mod:`nsrmp_bench.reference_model.program`): words as concepts, a role parser,
relations on the current state, a splitter trained on what the boxes show, and the 3D
action rule. See ``MODEL_CARD.md`` beside this file.
"""

from __future__ import annotations

from pathlib import Path

from nsrmp_bench.reference_model.nsrm2.config import NSRM2Config
from nsrmp_bench.reference_model.nsrm2.model import ConceptStepModel
from nsrmp_bench.reference_model.program.run import ProgramPredictor, train_program_model

__all__ = ["MODEL_ID", "NSRM2Config", "NSRM2Predictor", "train_nsrm2"]

MODEL_ID = "nsrm-v2"


def train_nsrm2(data: Path, out: Path, *, seed: int = 0, config: NSRM2Config | None = None,
                quiet: bool = False) -> Path:
    """Train on ``data/train``, select on ``data/val``; returns ``out/best.pt``."""
    cfg = config or NSRM2Config()
    return train_program_model(MODEL_ID, lambda v: ConceptStepModel(v, cfg), cfg, data, out,
                               seed=seed, quiet=quiet)


class NSRM2Predictor(ProgramPredictor):
    """A loaded NSRM v2."""

    model_id = MODEL_ID
    config_cls = NSRM2Config

    def __init__(self, checkpoint: Path) -> None:
        super().__init__(checkpoint, ConceptStepModel)
