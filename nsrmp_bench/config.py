"""What one instance must look like: a frozen config that only validates."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.vocabulary import COLOURS, PHENOMENA, PHRASINGS, SHAPES

__all__ = [
    "ALL_PAIRS", "HELD_OUT_MODES", "PHENOMENON_PHRASINGS", "RELATIONAL_POLICIES", "EpisodeConfig",
]

ALL_PAIRS: tuple[tuple[str, str], ...] = tuple((s, c) for s in SHAPES for c in COLOURS)
"""Every (shape, colour) combination."""

RELATIONAL_POLICIES = ("none", "any", "needed", "redundant")
"""none: no relations; any: at least one relational reference; needed: at least one
relational reference whose object's attributes alone are ambiguous; redundant: relational
references only where attributes alone would do."""

HELD_OUT_MODES = ("exclude", "require")
"""exclude: in-distribution language only; require: at least one held-out template or
synonym in every instruction (the language split)."""

PHENOMENON_PHRASINGS = ("seen", "held_out")
"""seen: the phenomena phrasings of every part; held_out: those kept for the semantics
split's test part only (``generators/templates/phenomena.json``)."""


@dataclass(frozen=True)
class EpisodeConfig:
    """The categories one instance is generated in."""

    objects: int = 5
    steps: int = 1
    relational: str = "none"
    phrasing: str = "simple"
    held_out: str = "exclude"
    pairs: tuple[tuple[str, str], ...] = ALL_PAIRS
    required_pairs: tuple[tuple[str, str], ...] = ()
    duplicates: int | None = None
    phenomenon: str = ""
    phenomenon_phrasing: str = "seen"

    def __post_init__(self) -> None:
        if self.phenomenon and self.phenomenon not in PHENOMENA:
            msg = f"phenomenon={self.phenomenon!r}; expected one of {list(PHENOMENA)} or ''"
            raise InvalidArgument(msg)
        if self.phenomenon_phrasing not in PHENOMENON_PHRASINGS:
            msg = (f"phenomenon_phrasing={self.phenomenon_phrasing!r}; expected one of "
                   f"{list(PHENOMENON_PHRASINGS)}")
            raise InvalidArgument(msg)
        if self.relational not in RELATIONAL_POLICIES:
            msg = f"relational={self.relational!r}; expected one of {list(RELATIONAL_POLICIES)}"
            raise InvalidArgument(msg)
        if self.phrasing not in PHRASINGS:
            msg = f"phrasing={self.phrasing!r}; expected one of {list(PHRASINGS)}"
            raise InvalidArgument(msg)
        if self.held_out not in HELD_OUT_MODES:
            msg = f"held_out={self.held_out!r}; expected one of {list(HELD_OUT_MODES)}"
            raise InvalidArgument(msg)
        bad = [p for p in (*self.pairs, *self.required_pairs) if tuple(p) not in ALL_PAIRS]
        if bad:
            msg = f"unknown (shape, colour) pairs {bad}; shapes {SHAPES}, colours {COLOURS}"
            raise InvalidArgument(msg)

    @property
    def forced_duplicates(self) -> int:
        """Duplicate (shape, colour) objects to force into the scene."""
        if self.duplicates is not None:
            return self.duplicates
        return 1 if self.relational == "needed" or self.phenomenon == "ambiguous" else 0

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form."""
        data = asdict(self)
        data["pairs"] = [list(p) for p in self.pairs]
        data["required_pairs"] = [list(p) for p in self.required_pairs]
        return data
