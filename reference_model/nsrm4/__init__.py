"""NSRM v4 (``nsrm-v4``): NSRM v3's networks behind the reader of sentence structure
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
from nsrmp_bench.reference_model.nsrm2 import NSRM2Model
from nsrmp_bench.reference_model.nsrm3 import NSRM3Config

__all__ = ["MODEL_ID", "NSRM4Config", "NSRM4Model"]

MODEL_ID = "nsrm-v4"


@dataclass(frozen=True)
class NSRM4Config(NSRM3Config, StructureSettings):
    """NSRM v3's configuration and the structure reader's settings."""


class NSRM4Model(StructureReadingModel, NSRM2Model):
    """NSRM v4: NSRM v3's networks behind the reader of sentence structure."""

    model_id = MODEL_ID
    config_cls: ClassVar[type[ModelConfig]] = NSRM4Config
