"""NMN+ v2 (``nmn-v2``): the attention baseline on NSRM v2's parts (perception, splitter,
action rule, training objective, inference); only the step model differs. See
``MODEL_CARD.md`` beside this file.
"""

from __future__ import annotations

from typing import ClassVar

from nsrmp_bench.reference_model.contract import ModelConfig
from nsrmp_bench.reference_model.nmn2.config import NMN2Config
from nsrmp_bench.reference_model.nmn2.model import AttentionStepModel
from nsrmp_bench.reference_model.program.run import ProgramModelBase

__all__ = ["MODEL_ID", "NMN2Config", "NMN2Model"]

MODEL_ID = "nmn-v2"


class NMN2Model(ProgramModelBase):
    """NMN+ v2: the attention step model on the shared program parts."""

    model_id = MODEL_ID
    config_cls: ClassVar[type[ModelConfig]] = NMN2Config

    @classmethod
    def step_model(cls, config: NMN2Config, vocab_size: int) -> AttentionStepModel:
        return AttentionStepModel(vocab_size, config)
