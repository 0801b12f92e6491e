"""NMN+ v2 (``nmn-v2``): the attention baseline on NSRM v2's parts (perception, splitter,
action rule, training objective, inference); only the step model differs. See
``MODEL_CARD.md`` beside this file.
"""

from __future__ import annotations

from pathlib import Path

from nsrmp_bench.reference_model.nmn2.config import NMN2Config
from nsrmp_bench.reference_model.nmn2.model import AttentionStepModel
from nsrmp_bench.reference_model.program.run import ProgramPredictor, train_program_model

__all__ = ["MODEL_ID", "NMN2Config", "NMN2Predictor", "train_nmn2"]

MODEL_ID = "nmn-v2"


def train_nmn2(data: Path, out: Path, *, seed: int = 0, config: NMN2Config | None = None,
               quiet: bool = False) -> Path:
    """Train on ``data/train``, select on ``data/val``; returns ``out/best.pt``."""
    cfg = config or NMN2Config()
    return train_program_model(MODEL_ID, lambda v: AttentionStepModel(v, cfg), cfg, data,
                               out, seed=seed, quiet=quiet)


class NMN2Predictor(ProgramPredictor):
    """A loaded NMN+ v2."""

    model_id = MODEL_ID
    config_cls = NMN2Config

    def __init__(self, checkpoint: Path) -> None:
        super().__init__(checkpoint, AttentionStepModel)
