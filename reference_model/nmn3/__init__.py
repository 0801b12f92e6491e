"""NMN+ v3 (``nmn-v3``): NMN+ v2's networks behind the same language front end as NSRM v3,
so that the two stay compared on equal terms. See ``MODEL_CARD.md`` beside this file.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from nsrmp_bench.reference_model.contract import ModelConfig
from nsrmp_bench.reference_model.language.reading import LanguageSettings, ReadingModel
from nsrmp_bench.reference_model.nmn2 import NMN2Config, NMN2Model
from nsrmp_bench.reference_model.program.size_calibration import SizeCalibration

__all__ = ["MODEL_ID", "NMN3Config", "NMN3Model"]

MODEL_ID = "nmn-v3"


@dataclass(frozen=True)
class NMN3Config(NMN2Config, LanguageSettings, SizeCalibration):
    """NMN+ v2's configuration, the language front end's settings and the size
    calibration's."""


class NMN3Model(ReadingModel, NMN2Model):
    """NMN+ v3: NMN+ v2 behind the language front end."""

    model_id = MODEL_ID
    config_cls: ClassVar[type[ModelConfig]] = NMN3Config
