"""NSRM v3 (``nsrm-v3``): NSRM v2's networks reading what a person says through the
language front end (:mod:`nsrmp_bench.reference_model.language`). See ``MODEL_CARD.md``
beside this file.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from nsrmp_bench.reference_model.contract import ModelConfig
from nsrmp_bench.reference_model.language.reading import LanguageSettings, ReadingModel
from nsrmp_bench.reference_model.nsrm2 import NSRM2Config, NSRM2Model
from nsrmp_bench.reference_model.program.size_calibration import SizeCalibration

__all__ = ["MODEL_ID", "NSRM3Config", "NSRM3Model"]

MODEL_ID = "nsrm-v3"


@dataclass(frozen=True)
class NSRM3Config(NSRM2Config, LanguageSettings, SizeCalibration):
    """NSRM v2's configuration, the language front end's settings and the size
    calibration's."""


class NSRM3Model(ReadingModel, NSRM2Model):
    """NSRM v3: NSRM v2 behind the language front end."""

    model_id = MODEL_ID
    config_cls: ClassVar[type[ModelConfig]] = NSRM3Config
