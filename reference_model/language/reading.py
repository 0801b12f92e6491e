"""The language front end on a program model: read each instruction before the model does.

:class:`ReadingModel` is the part ``nsrm-v3`` and ``nmn-v3`` share over their v2 networks:
every item's instruction is checked, read by the :class:`~.front_end.FrontEnd` built on
the model's vocabulary, and the model decodes the reading; an instruction that asks for no
action (nothing left to read) gets the empty program. The front end's settings are the
:class:`LanguageSettings` fields of the model's config. Its perception reads each scene's
object sizes through the size calibration
(:mod:`~nsrmp_bench.reference_model.program.size_calibration`, the
:class:`~nsrmp_bench.reference_model.program.size_calibration.SizeCalibration` fields).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import torch

from nsrmp_bench.instruction_check import check_instruction
from nsrmp_bench.reference_model.language.front_end import FrontEnd, Reading
from nsrmp_bench.reference_model.program.data import ProgramData
from nsrmp_bench.reference_model.program.inference import Decoded, Oracle
from nsrmp_bench.reference_model.program.run import ProgramModelBase
from nsrmp_bench.reference_model.program.size_calibration import (
    SizeCalibration,
    SizePrior,
    calibrated_sizes,
)

__all__ = ["LanguageSettings", "ReadingModel", "build_front_end"]

EMPTY_READING = "."
"""What the network decodes for an instruction that asks for nothing (its program is then
replaced by the empty one)."""


@dataclass(frozen=True)
class LanguageSettings:
    """The front end's settings (fields of the v3 configs)."""

    typo_edits: int = 2  # edits allowed in a typo of a word of typo_long letters or more
    typo_long: int = 6
    typo_min: int = 3  # shorter words are never corrected
    synonyms: bool = True  # nearest known word by sentence embedding (language extra)
    synonym_threshold: float = 0.6
    synonym_margin: float = 0.0


def build_front_end(vocab: Sequence[str], settings: Any) -> FrontEnd:
    """The front end over ``vocab`` with ``settings`` (a config holding the
    :class:`LanguageSettings` fields)."""
    from nsrmp_bench.reference_model.language.embeddings import Embeddings, english_words

    synonyms = (Embeddings(settings.synonym_threshold, settings.synonym_margin)
                if settings.synonyms else None)
    return FrontEnd(vocab, typo_edits=settings.typo_edits, typo_long=settings.typo_long,
                    typo_min=settings.typo_min, synonyms=synonyms, english=english_words())


class ReadingModel(ProgramModelBase):
    """A program model whose instructions pass the language front end first."""

    _front_end: FrontEnd | None = None
    _size_prior: SizePrior | None = None

    def front_end(self) -> FrontEnd:
        """The front end over this model's vocabulary (made once)."""
        if self._front_end is None:
            self._front_end = build_front_end(self.vocab.words, self.config)
        return self._front_end

    def perceived_sizes(self, sizes: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        """The sizes at each scene's calibrated scale (where the config has a size prior)."""
        cfg = self.config
        if not isinstance(cfg, SizeCalibration) or not cfg.size_calibration \
                or not cfg.size_prior:
            return sizes
        if self._size_prior is None:
            self._size_prior = SizePrior.from_values(cfg.size_prior)
        return calibrated_sizes(sizes, mask, self._size_prior, cfg)

    def readings(self, items: Sequence[Mapping[str, Any]]) -> list[Reading]:
        """How the model reads each item's instruction."""
        front = self.front_end()
        return [front.read(check_instruction(it["inputs"].get("instruction"),
                                             f"the instruction of episode {it['id']!r}"))
                for it in items]

    def _decode(self, items: Sequence[dict[str, Any]],
                oracle: Oracle | None = None) -> tuple[ProgramData, Decoded]:
        readings = self.readings(items)
        read = [{**it, "inputs": {**it["inputs"], "instruction": r.text or EMPTY_READING}}
                for it, r in zip(items, readings, strict=True)]
        data, decoded = super()._decode(read, oracle)
        for i, r in enumerate(readings):
            if r.empty:
                decoded.steps[i] = []
        return data, decoded
