"""Split specs: data files ``splits/<name>-vN.json``, loaded into frozen dataclasses.

A split has parts (train / val / test), each with a count, its own entropy and strata. A
stratum is a grid of categories (objects x steps x relational x phrasing); the part's cells
are the strata's grids in order, and instance ``i`` takes cell ``i mod len(cells)``, so
every category is balanced to within one instance. Instance ``i`` of a part is then a pure
function of (spec, part, i).

A part's entropy may be the word ``"secret"`` (:data:`PRIVATE_ENTROPY`): a *private* part,
whose entropy is derived from a secret given at generation and never written anywhere
(:mod:`nsrmp_bench.private_parts`); its manifest holds a commitment instead.

A spec may also come from a file of the same form (:func:`load_split_file`, or
:func:`resolve_split` for "an id or a path"): a custom split, e.g. 20,000 training episodes
or 3-8 objects. It is *unofficial*: validated like the shipped specs, written into its
manifests, never compared with a committed manifest; its id must not be a shipped one.
"""

from __future__ import annotations

import difflib
import itertools
import json
import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

from nsrmp_bench.config import (
    ALL_PAIRS,
    HELD_OUT_MODES,
    PHENOMENON_PHRASINGS,
    RELATIONAL_POLICIES,
    EpisodeConfig,
)
from nsrmp_bench.errors import InvalidArgument, UnknownId
from nsrmp_bench.vocabulary import (
    COLOURS,
    MAX_OBJECTS,
    MAX_STEPS,
    MIN_OBJECTS,
    PHENOMENA,
    PHRASINGS,
    SHAPES,
)

__all__ = [
    "OFFICIAL_SPLITS",
    "PRIVATE_ENTROPY",
    "SPLIT_ID_RE",
    "PartSpec",
    "SplitSpec",
    "Stratum",
    "list_splits",
    "load_split",
    "load_split_file",
    "resolve_split",
    "withdrawal",
]

PRIVATE_ENTROPY = "secret"
"""A part's ``entropy`` value that makes it private: the entropy comes from a secret."""
SPLIT_ID_RE = re.compile(r"^(?P<name>[a-z][a-z0-9]*)-v(?P<version>[0-9]+)$")
OFFICIAL_SPLITS = (
    "smoke-v2", "paper-v2", "objects-v2", "steps-v2", "attributes-v2", "language-v2",
    "robot-v2", "semantics-v1",
)
"""The official benchmark set. A shipped split outside it is training material
(``dense5x-v2``, the dense baseline's 5x data): generated, verified and audited like the
others, with a committed manifest, but it has no test part and no leaderboard."""


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
    phenomena: tuple[str, ...] = ()
    """The meaning phenomena of the grid (the semantics split); () for ordinary ones."""
    phenomenon_phrasing: tuple[str, ...] = ("seen",)
    """Which phrasings of ``phenomena.json`` the grid uses: seen, held_out (test only)."""

    def cells(self) -> list[tuple[int, int, str, str, str, str]]:
        """The grid's combinations in a fixed order, the phenomenon varying fastest (so
        any run of consecutive instances is balanced over the phenomena); a grid without
        phenomena has phenomenon "" and the order it always had."""
        return list(itertools.product(
            self.objects, self.steps, self.relational, self.phrasing,
            self.phenomenon_phrasing, self.phenomena or ("",),
        ))

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str) -> Stratum:
        """Parse a stratum; unknown keys are an error."""
        known = {"objects", "steps", "relational", "phrasing", "held_out", "pairs",
                 "required_pairs", "phenomena", "phenomenon_phrasing"}
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
                phenomena=tuple(str(v) for v in data.get("phenomena", ())),
                phenomenon_phrasing=tuple(str(v) for v in data.get("phenomenon_phrasing",
                                                                   ("seen",))),
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
    entropy: int | None = field(repr=False)
    """The part's entropy; None for a private part whose secret has not been given (a
    private part's derived entropy is kept out of ``repr``, so no log shows it)."""
    strata: tuple[Stratum, ...]
    private: bool = False
    """Whether the entropy comes from a secret (the spec says ``"entropy": "secret"``)."""
    cell_stride: int = 1
    """Instance ``i`` takes cell ``(i * cell_stride) mod cells``: a stride coprime to the
    number of cells spreads a count that is no multiple of it over every category (the
    spec's ``"cell_stride"``; 1, the default, is the plain order)."""

    def missing_secret(self, split_id: str) -> InvalidArgument:
        """The error of using this private part without its secret: how to give it."""
        return InvalidArgument(
            f"part {self.name!r} of split {split_id} is private (its entropy is "
            f"{PRIVATE_ENTROPY!r}): give its secret with --secret-file PATH or the "
            "environment variable NSRMP_BENCH_SECRET")

    def seed_entropy(self, split_id: str) -> int:
        """The entropy instances are drawn from; a private part without its secret is an
        error saying how to give it."""
        if self.entropy is None:
            raise self.missing_secret(split_id)
        return self.entropy

    def cells(self) -> list[tuple[Stratum, tuple[int, int, str, str, str, str]]]:
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
    source: str | None = None
    """The spec file of an unofficial split; None for a spec shipped with the package."""
    raw: Mapping[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def shipped(self) -> bool:
        """Whether the spec is one shipped with the package (else a custom spec file)."""
        return self.source is None

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
        stratum, (objects, steps, relational, phrasing, wording, phenomenon) = cells[
            (index * spec.cell_stride) % len(cells)]
        pairs = ALL_PAIRS
        if stratum.pairs == "in_distribution":
            pairs = tuple(p for p in ALL_PAIRS if p not in self.held_out_pairs)
        required = self.held_out_pairs if stratum.required_pairs == "held_out" else ()
        return EpisodeConfig(
            objects=objects, steps=steps, relational=relational, phrasing=phrasing,
            held_out=stratum.held_out, pairs=pairs, required_pairs=required,
            phenomenon=phenomenon, phenomenon_phrasing=wording,
        )

    def episode_id(self, part: str, index: int) -> str:
        """The id of instance ``index`` of ``part``, e.g. ``paper-v2-train-000042``."""
        return f"{self.id}-{part}-{index:06d}"

    def to_dict(self) -> dict[str, Any]:
        """The spec as read (its canonical form, stored in manifests)."""
        out: dict[str, Any] = json.loads(json.dumps(self.raw))
        return out


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
    return _parse(data, where, source=None)


def load_split_file(path: str | os.PathLike[str]) -> SplitSpec:
    """A split spec from a JSON file of the shipped specs' form (an unofficial split).

    A file that repeats a shipped spec exactly is that shipped split; one that reuses a
    shipped id with other content is refused (give the split its own id).
    """
    p = Path(path)
    try:
        data = json.loads(p.read_text("utf-8"))
    except FileNotFoundError as exc:
        msg = f"split spec file {str(p)!r} does not exist; pass a split id or a spec file path"
        raise InvalidArgument(msg) from exc
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        msg = (f"split spec file {str(p)!r} is not readable JSON ({exc}); write it like "
               "the shipped specs (e.g. splits/paper-v2.json)")
        raise InvalidArgument(msg) from exc
    if not isinstance(data, dict):
        msg = f"{p}: a split spec is a JSON object, got {type(data).__name__}"
        raise InvalidArgument(msg)
    split_id = data.get("id")
    if not isinstance(split_id, str) or not SPLIT_ID_RE.match(split_id):
        msg = (f"{p}: 'id' is {split_id!r}; a split id is name-vN with a lowercase name of "
               "letters and digits, e.g. 'mysplit-v1'")
        raise InvalidArgument(msg)
    if _read_text(split_id) is not None:
        if data == _raw(split_id):
            return load_split(split_id)
        msg = (f"{p}: id {split_id!r} is a shipped split but the spec differs from it; give "
               f"your split its own id (e.g. 'my{split_id}'), so its data is never taken for "
               "the official one")
        raise InvalidArgument(msg)
    return _parse(data, str(p), source=str(p))


def resolve_split(split: str) -> SplitSpec:
    """A shipped split by id (``paper-v2``), or a spec file by path (``./my-split.json``)."""
    if split.endswith(".json") or os.sep in split or "/" in split or Path(split).is_file():
        return load_split_file(split)
    return load_split(split)


def _positive(value: object, what: str, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        msg = f"{where}: {what} is {value!r}; expected a non-negative integer"
        raise InvalidArgument(msg)
    return value


def _entropy(value: object, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        msg = (f"{where}: entropy is {value!r}; expected a non-negative integer, or "
               f"{PRIVATE_ENTROPY!r} for a private part (its secret given at generation)")
        raise InvalidArgument(msg)
    return value


MIN_IMAGE, MAX_IMAGE = 32, 4096
"""The image sizes a spec may ask for, in pixels per side."""


def _check_stratum(s: Stratum, where: str) -> None:
    """Every value of a stratum, named by its JSON path (``...strata[2].steps[0]``)."""
    checks: tuple[tuple[str, tuple[Any, ...], Any, str], ...] = (
        ("objects", s.objects, lambda n: MIN_OBJECTS <= n <= MAX_OBJECTS,
         f"a number of objects in {MIN_OBJECTS}..{MAX_OBJECTS}"),
        ("steps", s.steps, lambda n: 1 <= n <= MAX_STEPS, f"a number of steps in 1..{MAX_STEPS}"),
        ("relational", s.relational, lambda v: v in RELATIONAL_POLICIES,
         f"one of {list(RELATIONAL_POLICIES)}"),
        ("phrasing", s.phrasing, lambda v: v in PHRASINGS, f"one of {list(PHRASINGS)}"),
    )
    for key, values, ok, expected in checks:
        if not values:
            msg = f"{where}.{key}: an empty list; expected at least one value, each {expected}"
            raise InvalidArgument(msg)
        for k, v in enumerate(values):
            if not ok(v):
                msg = f"{where}.{key}[{k}]: {v!r}; expected {expected}"
                raise InvalidArgument(msg)
    if s.held_out not in HELD_OUT_MODES:
        msg = f"{where}.held_out: {s.held_out!r}; expected one of {list(HELD_OUT_MODES)}"
        raise InvalidArgument(msg)
    for k, v in enumerate(s.phenomena):
        if v not in PHENOMENA:
            msg = f"{where}.phenomena[{k}]: {v!r}; expected one of {list(PHENOMENA)}"
            raise InvalidArgument(msg)
    for k, v in enumerate(s.phenomenon_phrasing):
        if v not in PHENOMENON_PHRASINGS:
            msg = (f"{where}.phenomenon_phrasing[{k}]: {v!r}; expected one of "
                   f"{list(PHENOMENON_PHRASINGS)}")
            raise InvalidArgument(msg)


def _parse(data: Mapping[str, Any], where: str, *, source: str | None) -> SplitSpec:
    """A :class:`SplitSpec` from a spec's JSON object, every problem named with ``where``."""
    missing = [k for k in ("id", "description", "image", "parts") if k not in data]
    if missing:
        msg = f"{where}: missing keys {missing}; see splits/paper-v2.json for the form"
        raise InvalidArgument(msg)
    if not isinstance(data["parts"], dict) or not data["parts"]:
        msg = f"{where}: 'parts' must map part names (train, val, test) to parts"
        raise InvalidArgument(msg)
    parts = {}
    for name, part in data["parts"].items():
        pw = f"{where} parts.{name}"
        if not isinstance(part, dict) or not {"count", "entropy", "strata"} <= set(part):
            msg = f"{pw}: a part needs 'count', 'entropy' and 'strata'"
            raise InvalidArgument(msg)
        if not isinstance(part["strata"], list) or not part["strata"]:
            msg = f"{pw}.strata: expected a non-empty list of strata"
            raise InvalidArgument(msg)
        strata = tuple(
            Stratum.from_dict(s, f"{pw}.strata[{i}]") for i, s in enumerate(part["strata"])
        )
        for i, s in enumerate(strata):
            _check_stratum(s, f"{pw}.strata[{i}]")
        count = _positive(part["count"], "count", pw)
        if count == 0:
            msg = f"{pw}: count is 0; a part needs at least one instance"
            raise InvalidArgument(msg)
        stride = _positive(part.get("cell_stride", 1), "cell_stride", pw)
        n_cells = sum(len(s.cells()) for s in strata)
        if math.gcd(stride, n_cells) != 1:
            msg = (f"{pw}.cell_stride: {stride} shares a factor with the part's {n_cells} "
                   "cells, so some cells would never be drawn; use a stride coprime to it "
                   "(1 always is)")
            raise InvalidArgument(msg)
        if part["entropy"] == PRIVATE_ENTROPY:
            parts[name] = PartSpec(name, count, None, strata, private=True, cell_stride=stride)
        else:
            entropy = _entropy(part["entropy"], pw)
            parts[name] = PartSpec(name, count, entropy, strata, cell_stride=stride)
    try:
        image = (int(data["image"][0]), int(data["image"][1]))
        held_out_pairs = tuple((str(s), str(c)) for s, c in data.get("held_out_pairs", ()))
    except (TypeError, ValueError, IndexError) as exc:
        msg = (f"{where}: 'image' must be [width, height] and 'held_out_pairs' a list of "
               f"[shape, colour] ({exc})")
        raise InvalidArgument(msg) from exc
    for k, (size, got) in enumerate(zip(image, data["image"], strict=False)):
        if not MIN_IMAGE <= size <= MAX_IMAGE or size != got or len(data["image"]) != 2:
            msg = (f"{where} image[{k}]: {got!r}; 'image' is [width, height] in pixels, two "
                   f"integers in {MIN_IMAGE}..{MAX_IMAGE} (the official images are [320, 240])")
            raise InvalidArgument(msg)
    for k, pair in enumerate(held_out_pairs):
        if pair not in ALL_PAIRS:
            msg = (f"{where} held_out_pairs[{k}]: {list(pair)} is not a [shape, colour]; "
                   f"shapes {list(SHAPES)}, colours {list(COLOURS)}")
            raise InvalidArgument(msg)
    spec = SplitSpec(
        id=str(data["id"]),
        description=str(data["description"]),
        changes=str(data.get("changes", "")),
        generator=str(data.get("generator", "symbolic-v1")),
        executor=str(data.get("executor", "teleport")),
        image=image,
        held_out_pairs=held_out_pairs,
        parts=parts,
        source=source,
        raw=json.loads(json.dumps(data)),
    )
    for name, ps in parts.items():  # every cell's config validates (relational, phrasing ...)
        for k in range(min(ps.count, len(ps.cells()))):
            spec.config(name, k)
    return spec
