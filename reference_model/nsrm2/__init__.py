"""NSRM v2 (``nsrm-v2``), the neuro-symbolic reference model rebuilt on the shared program
parts (:mod:`nsrmp_bench.reference_model.program`): words as concepts, a role parser,
relations on the current state, a splitter trained on what the boxes show, and the 3D
action rule. See ``MODEL_CARD.md`` beside this file.
"""

from __future__ import annotations

from typing import ClassVar

from nsrmp_bench.reference_model.contract import ModelConfig
from nsrmp_bench.reference_model.nsrm2.config import NSRM2Config
from nsrmp_bench.reference_model.nsrm2.model import ConceptStepModel
from nsrmp_bench.reference_model.program.run import ProgramModelBase

__all__ = ["MODEL_ID", "NSRM2Config", "NSRM2Model"]

MODEL_ID = "nsrm-v2"


class NSRM2Model(ProgramModelBase):
    """NSRM v2: the concept step model on the shared program parts."""

    model_id = MODEL_ID
    config_cls: ClassVar[type[ModelConfig]] = NSRM2Config

    @classmethod
    def step_model(cls, config: NSRM2Config, vocab_size: int) -> ConceptStepModel:
        return ConceptStepModel(vocab_size, config)
