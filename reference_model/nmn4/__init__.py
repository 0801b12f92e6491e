"""NMN+ v4 (``nmn-v4``): NMN+ v3's networks behind the reader of sentence structure
(:mod:`nsrmp_bench.reference_model.language.structure`, then v3's front end). See
``MODEL_CARD.md`` beside this file.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from nsrmp_bench.reference_model.contract import ModelConfig
from nsrmp_bench.reference_model.language.reading4 import (
    StructureReadingModel,
    StructureSettings,
)
from nsrmp_bench.reference_model.nmn2 import NMN2Model
from nsrmp_bench.reference_model.nmn3 import NMN3Config

__all__ = ["MODEL_ID", "NMN4Config", "NMN4Model"]

MODEL_ID = "nmn-v4"


@dataclass(frozen=True)
class NMN4Config(NMN3Config, StructureSettings):
    """NMN+ v3's configuration and the structure reader's settings."""


class NMN4Model(StructureReadingModel, NMN2Model):
    """NMN+ v4: NMN+ v3's networks behind the reader of sentence structure."""

    model_id = MODEL_ID
    config_cls: ClassVar[type[ModelConfig]] = NMN4Config
