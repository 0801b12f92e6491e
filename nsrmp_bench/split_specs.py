"""Split specs: data files ``splits/<name>-vN.json``, loaded into frozen dataclasses.

A split has parts (train / val / test), each with a count, its own entropy and strata. A
stratum is a grid of categories (objects x steps x relational x phrasing); the part's cells
are the strata's grids in order, and instance ``i`` takes cell ``i mod len(cells)``, so
every category is balanced to within one instance. Instance ``i`` of a part is then a pure
function of (spec, part, i).
"""

from __future__ import annotations

import difflib
import itertools
import json
import re
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

from nsrmp_bench.config import ALL_PAIRS, EpisodeConfig
from nsrmp_bench.errors import InvalidArgument, UnknownId

__all__ = [
    "OFFICIAL_SPLITS",
    "SPLIT_ID_RE",
    "PartSpec",
    "SplitSpec",
    "Stratum",
    "list_splits",
    "load_split",
    "withdrawal",
]

SPLIT_ID_RE = re.compile(r"^(?P<name>[a-z][a-z0-9]*)-v(?P<version>[0-9]+)$")
OFFICIAL_SPLITS = (
    "smoke-v2", "paper-v2", "objects-v2", "steps-v2", "attributes-v2", "language-v2",
    "robot-v2",
)
"""The official benchmark set."""


@dataclass(frozen=True)
class Stratum:
    """A grid of categories; every combination is one cell."""

    objects: tuple[int, ...]
    steps: tuple[int, ...]
    relational: tuple[str, ...] = ("none",)
    phrasing: tuple[str, ...] = ("simple",)
    held_out: str = "exclude"
    pairs: str = "all"  # all | in_distribution (without the spec's held-out pairs)
    required_pairs: str = "none"  # none | held_out (a step must involve a held-out pair)

    def cells(self) -> list[tuple[int, int, str, str]]:
        """The grid's combinations in a fixed order."""
        return list(itertools.product(self.objects, self.steps, self.relational, self.phrasing))

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str) -> Stratum:
        """Parse a stratum; unknown keys are an error."""
        known = {"objects", "steps", "relational", "phrasing", "held_out", "pairs",
                 "required_pairs"}
        extra = set(data) - known
        if extra:
            msg = f"{where}: unknown keys {sorted(extra)}; a stratum has {sorted(known)}"
            raise InvalidArgument(msg)
        try:
            out = cls(
                objects=tuple(int(v) for v in data["objects"]),
                steps=tuple(int(v) for v in data["steps"]),
                relational=tuple(data.get("relational", ("none",))),
                phrasing=tuple(data.get("phrasing", ("simple",))),
                held_out=str(data.get("held_out", "exclude")),
                pairs=str(data.get("pairs", "all")),
                required_pairs=str(data.get("required_pairs", "none")),
            )
        except (KeyError, TypeError, ValueError) as exc:
            msg = f"{where}: a stratum needs lists 'objects' and 'steps' of integers ({exc})"
            raise InvalidArgument(msg) from exc
        if out.pairs not in ("all", "in_distribution"):
            msg = f"{where}: pairs={out.pairs!r}; expected 'all' or 'in_distribution'"
            raise InvalidArgument(msg)
        if out.required_pairs not in ("none", "held_out"):
            msg = f"{where}: required_pairs={out.required_pairs!r}; expected 'none' or 'held_out'"
            raise InvalidArgument(msg)
        return out


@dataclass(frozen=True)
class PartSpec:
    """One part of a split (e.g. train)."""

    name: str
    count: int
    entropy: int
    strata: tuple[Stratum, ...]

    def cells(self) -> list[tuple[Stratum, tuple[int, int, str, str]]]:
        """Every (stratum, cell) in order."""
        return [(s, c) for s in self.strata for c in s.cells()]


@dataclass(frozen=True)
class SplitSpec:
    """A split: its parts, how it differs from paper-v2, and how it is realised."""

    id: str
    description: str
    changes: str
    generator: str
    executor: str
    image: tuple[int, int]
    held_out_pairs: tuple[tuple[str, str], ...]
    parts: dict[str, PartSpec]

    def part(self, name: str) -> PartSpec:
        """The part called ``name``, or UnknownId listing the parts."""
        if name not in self.parts:
            msg = f"split {self.id} has no part {name!r}; its parts are {sorted(self.parts)}"
            raise UnknownId(msg)
        return self.parts[name]

    def config(self, part: str, index: int) -> EpisodeConfig:
        """The category config of instance ``index`` of ``part``."""
        spec = self.part(part)
        if not 0 <= index < spec.count:
            msg = f"{self.id}/{part} has instances 0..{spec.count - 1}, got index {index}"
            raise InvalidArgument(msg)
        cells = spec.cells()
        stratum, (objects, steps, relational, phrasing) = cells[index % len(cells)]
        pairs = ALL_PAIRS
        if stratum.pairs == "in_distribution":
            pairs = tuple(p for p in ALL_PAIRS if p not in self.held_out_pairs)
        required = self.held_out_pairs if stratum.required_pairs == "held_out" else ()
        return EpisodeConfig(
            objects=objects, steps=steps, relational=relational, phrasing=phrasing,
            held_out=stratum.held_out, pairs=pairs, required_pairs=required,
        )

    def episode_id(self, part: str, index: int) -> str:
        """The id of instance ``index`` of ``part``, e.g. ``paper-v2-train-000042``."""
        return f"{self.id}-{part}-{index:06d}"

    def to_dict(self) -> dict[str, Any]:
        """The spec as read (its canonical form, stored in manifests)."""
        return _raw(self.id)


def _read_text(split_id: str) -> str | None:
    path = resources.files("nsrmp_bench.splits").joinpath(f"{split_id}.json")
    return path.read_text("utf-8") if path.is_file() else None


@cache
def list_splits(*, withdrawn: bool = False) -> tuple[str, ...]:
    """Every split id shipped with the package; the withdrawn ones only when asked."""
    root = resources.files("nsrmp_bench.splits")
    ids = [p.name[:-5] for p in root.iterdir() if p.name.endswith(".json")]
    return tuple(sorted(i for i in ids if SPLIT_ID_RE.match(i)
                        and withdrawn == ("withdrawn" in _raw(i))))


def _unknown(split_id: str) -> UnknownId:
    known = list_splits()
    m = SPLIT_ID_RE.match(split_id)
    same_name = [k for k in known if m and k.startswith(m.group("name") + "-v")]
    if same_name:
        msg = f"split {split_id!r} does not exist; versions of it that do: {same_name}"
    else:
        close = difflib.get_close_matches(split_id, known, n=3)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        msg = f"unknown split {split_id!r}{hint} Known splits: {', '.join(known)}"
    return UnknownId(msg)


@cache
def _raw(split_id: str) -> dict[str, Any]:
    text = _read_text(split_id) if SPLIT_ID_RE.match(split_id) else None
    if text is None:
        raise _unknown(split_id)
    data: dict[str, Any] = json.loads(text)
    return data


def withdrawal(split_id: str) -> dict[str, str] | None:
    """``{"use": successor, "why": reason}`` when ``split_id`` was withdrawn; None when it
    is current or unknown."""
    try:
        gone = _raw(split_id).get("withdrawn")
    except UnknownId:
        return None
    return None if gone is None else {"use": str(gone["use"]), "why": str(gone["why"])}


@cache
def load_split(split_id: str) -> SplitSpec:
    """The spec of ``split_id`` (``name-vN``); UnknownId with suggestions if absent."""
    data = _raw(split_id)
    where = f"splits/{split_id}.json"
    gone = withdrawal(split_id)
    if gone is not None:
        msg = (f"split {split_id!r} was withdrawn: {gone['why']}. Use {gone['use']!r} "
               f"(the same spec, reproducible bytes)")
        raise UnknownId(msg)
    if data.get("id") != split_id:
        msg = f"{where}: its 'id' is {data.get('id')!r}; it must equal the file name"
        raise InvalidArgument(msg)
    parts = {}
    for name, part in data["parts"].items():
        strata = tuple(
            Stratum.from_dict(s, f"{where} parts.{name}.strata[{i}]")
            for i, s in enumerate(part["strata"])
        )
        parts[name] = PartSpec(name, int(part["count"]), int(part["entropy"]), strata)
    return SplitSpec(
        id=split_id,
        description=str(data["description"]),
        changes=str(data.get("changes", "")),
        generator=str(data.get("generator", "symbolic-v1")),
        executor=str(data.get("executor", "teleport")),
        image=(int(data["image"][0]), int(data["image"][1])),
        held_out_pairs=tuple((str(s), str(c)) for s, c in data.get("held_out_pairs", ())),
        parts=parts,
    )
