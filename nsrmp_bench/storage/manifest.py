"""``manifest.json``: the split's shards, counts, per-episode hashes and root hash.

Layout (keys sorted; one episode row per line, so diffs stay readable)::

    {
     "format": "nsrmp-bench-manifest",
     "schema_version": "1.0.0",
     "split": "...", "generator": "...", "versions": {...caller's versions...},
     "index_range": [start, stop],
     "counts": {"episodes": n, "shards": k, "steps": {...}, "objects": {...},
                "relational": {...}, "phrasing": {...}},
     "root_hash": "<sha256 over [index, episode hash] pairs in index order>",
     "shards": [{"file", "index_range", "count", "sha256", "bytes", "split"}, ...],
     "episodes": [{"index", "id", "hash", "steps", "objects", "relational",
                   "relation_needed", "phrasing", "template"[, "tolerant"]}, ...]
     ["comparison": {...}]  only with robot episodes: how they are compared
     ["official": false, "spec": {...}]  only for a split generated from a spec file
     ["private": {"scheme", "commitment"}]  only for a private part (its entropy a secret)
     ["inputs_only": true]  only for a part packed without its gold (rows keep index, id,
                            hash, objects; counts only episodes, shards, objects)
    }

Robot episodes are not bit-stable across CPUs: their rows carry a ``tolerant`` summary and
the manifest a ``comparison`` section stating the tolerances (``storage/tolerance.py``).

The manifest carries no timestamp: the same episodes give the same manifest bytes.
"""

from __future__ import annotations

import itertools
import json
import os
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.episode import SCHEMA_VERSION
from nsrmp_bench.errors import DataIntegrityError, InvalidArgument
from nsrmp_bench.storage.hashing import root_hash
from nsrmp_bench.storage.layout import check_schema_version
from nsrmp_bench.storage.records import EpisodeEntry, ShardRecord, atomic_write_text
from nsrmp_bench.storage.tolerance import comparison_spec

__all__ = ["MANIFEST_FORMAT", "MANIFEST_NAME", "Manifest", "build_manifest", "read_manifest"]

MANIFEST_NAME = "manifest.json"
MANIFEST_FORMAT = "nsrmp-bench-manifest"


def _key(value: object) -> str:
    return value if isinstance(value, str) else json.dumps(value)


def _counts(records: Sequence[ShardRecord], *, inputs_only: bool = False) -> dict[str, Any]:
    eps = [e for r in records for e in r.episodes]
    out: dict[str, Any] = {"episodes": len(eps), "shards": len(records)}
    for key in ("objects",) if inputs_only else ("steps", "objects", "relational", "phrasing"):
        c = Counter(_key(e.categories.get(key)) for e in eps)
        out[key] = dict(sorted(c.items()))
    if not inputs_only and any("phenomenon" in e.categories for e in eps):
        c = Counter(str(e.categories.get("phenomenon", "")) for e in eps)
        out["phenomenon"] = dict(sorted(c.items()))
    return out


@dataclass(frozen=True)
class Manifest:
    """A split's manifest: its shards in index order, with hashes."""

    split: str
    generator: str
    schema_version: str
    versions: dict[str, str]
    shards: tuple[ShardRecord, ...]
    root_hash: str
    spec: Mapping[str, Any] | None = None
    """The split spec of an unofficial split (generated from a spec file), else None."""
    perturbation: Mapping[str, Any] | None = None
    """What made a perturbed copy of a part (``nsrmp-bench perturb``: kind, seed, the source
    part's root hash, the per-instance records' sha256), else None."""
    private: Mapping[str, str] | None = None
    """A private part's commitment to its secret (:mod:`nsrmp_bench.private_parts`)."""
    inputs_only: bool = False
    """Whether the part was packed without its gold (:mod:`nsrmp_bench.storage.inputs_only`)."""

    @property
    def official(self) -> bool:
        """False for data of an unofficial split (its manifest holds the spec) and for a
        perturbed copy of a part."""
        return self.spec is None and self.perturbation is None

    @property
    def episodes(self) -> tuple[EpisodeEntry, ...]:
        """Every episode entry, in index order."""
        return tuple(e for s in self.shards for e in s.episodes)

    @property
    def count(self) -> int:
        """Number of episodes."""
        return sum(s.count for s in self.shards)

    @property
    def index_range(self) -> tuple[int, int]:
        """``(start, stop)`` of the instance indices covered."""
        if not self.shards:
            return (0, 0)
        return (self.shards[0].start, self.shards[-1].stop)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        rows: list[dict[str, Any]] = []
        for s in self.shards:
            rows.extend({**e.to_dict(), "shard": s.file} for e in s.episodes)
        return {
            "format": MANIFEST_FORMAT,
            "schema_version": self.schema_version,
            "split": self.split,
            "generator": self.generator,
            "versions": dict(self.versions),
            "index_range": list(self.index_range),
            "counts": _counts(self.shards, inputs_only=self.inputs_only),
            "root_hash": self.root_hash,
            "shards": [s.to_dict(with_episodes=False) for s in self.shards],
            "episodes": rows,
            **({"comparison": comparison_spec()}
               if any(e.tolerant is not None for s in self.shards for e in s.episodes) else {}),
            **({"official": False, "spec": dict(self.spec)} if self.spec is not None else {}),
            **({"official": False, "perturbation": dict(self.perturbation)}
               if self.perturbation is not None else {}),
            **({"private": dict(self.private)} if self.private is not None else {}),
            **({"inputs_only": True} if self.inputs_only else {}),
        }

    def to_json(self) -> str:
        """Deterministic text: sorted keys, one shard or episode per line."""
        data = self.to_dict()
        lines = ["{"]
        keys = sorted(data)
        for n, key in enumerate(keys):
            value = data[key]
            end = "," if n < len(keys) - 1 else ""
            if isinstance(value, list) and value and isinstance(value[0], dict):
                lines.append(f" {json.dumps(key)}: [")
                lines.extend(
                    f"  {canonical_json(v)}{',' if i < len(value) - 1 else ''}"
                    for i, v in enumerate(value)
                )
                lines.append(f" ]{end}")
            else:
                lines.append(f" {json.dumps(key)}: {canonical_json(value)}{end}")
        lines.append("}")
        return "\n".join(lines) + "\n"

    def write(self, out_dir: str | os.PathLike[str]) -> Path:
        """Write ``out_dir/manifest.json`` atomically."""
        path = Path(out_dir) / MANIFEST_NAME
        atomic_write_text(path, self.to_json())
        return path

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "manifest") -> Manifest:
        """Inverse of :meth:`to_dict`; checks the format and schema version."""
        if data.get("format") != MANIFEST_FORMAT:
            msg = (
                f"{where}: format is {data.get('format')!r}, expected {MANIFEST_FORMAT!r}; "
                "this is not an nsrmp-bench manifest"
            )
            raise DataIntegrityError(msg)
        version = check_schema_version(data.get("schema_version"), where)
        by_shard: dict[str, list[EpisodeEntry]] = {}
        for row in data["episodes"]:
            by_shard.setdefault(str(row["shard"]), []).append(EpisodeEntry.from_dict(row))
        shards = tuple(
            ShardRecord.from_dict(s, tuple(by_shard.get(str(s["file"]), ())))
            for s in data["shards"]
        )
        return cls(
            split=str(data["split"]),
            generator=str(data.get("generator", "")),
            schema_version=version,
            versions={str(k): str(v) for k, v in data.get("versions", {}).items()},
            shards=shards,
            root_hash=str(data["root_hash"]),
            spec=dict(data["spec"]) if "spec" in data and data.get("official") is False
            else None,
            perturbation=dict(data["perturbation"]) if "perturbation" in data else None,
            private={str(k): str(v) for k, v in data["private"].items()}
            if isinstance(data.get("private"), dict) else None,
            inputs_only=data.get("inputs_only") is True,
        )


def build_manifest(
    records: Sequence[ShardRecord],
    *,
    split: str,
    generator: str | None = None,
    versions: Mapping[str, str] | None = None,
    spec: Mapping[str, Any] | None = None,
    private: Mapping[str, str] | None = None,
) -> Manifest:
    """A manifest over ``records``, which must tile a contiguous index range.

    ``generator`` defaults to the generator ids the shards record; ``spec`` is the split
    spec of an unofficial split (None for a shipped one); ``private`` a private part's
    commitment.
    """
    ordered = sorted(records, key=lambda r: r.start)
    for a, b in itertools.pairwise(ordered):
        if a.stop != b.start:
            kind = "overlap" if b.start < a.stop else "leave a gap"
            msg = (
                f"shards {a.file} and {b.file} {kind} (indices [{a.start}, {a.stop}) and "
                f"[{b.start}, {b.stop})); generate the missing shards or remove the extra one"
            )
            raise InvalidArgument(msg)
    for r in ordered:
        if r.count != r.stop - r.start:
            msg = (
                f"shard {r.file} covers {r.stop - r.start} indices but holds {r.count} "
                "episodes; regenerate it"
            )
            raise DataIntegrityError(msg)
        if r.split != split:
            msg = f"shard {r.file} belongs to split {r.split!r}, not {split!r}"
            raise InvalidArgument(msg)
    entries = [(e.index, e.hash) for r in ordered for e in r.episodes]
    if generator is None:
        ids = {g for r in ordered for g in r.generator.split(",") if g}
        generator = ",".join(sorted(ids))
    return Manifest(
        split=split,
        generator=generator,
        schema_version=SCHEMA_VERSION,
        versions=dict(sorted((versions or {}).items())),
        shards=tuple(ordered),
        root_hash=root_hash(entries),
        spec=spec,
        private=private,
    )


def read_manifest(path: str | os.PathLike[str]) -> Manifest:
    """Read ``manifest.json`` (or the one in a directory)."""
    p = Path(path)
    if p.is_dir():
        p = p / MANIFEST_NAME
    try:
        data = json.loads(p.read_text("utf-8"))
    except FileNotFoundError as exc:
        msg = (
            f"no manifest at {p}; a data directory gets its manifest.json when generation "
            "finishes: finish (resume) the generation, or open a single shard file instead"
        )
        raise DataIntegrityError(msg) from exc
    except (OSError, ValueError) as exc:
        msg = f"manifest {p} is unreadable or not JSON ({exc}); regenerate or re-download it"
        raise DataIntegrityError(msg) from exc
    try:
        return Manifest.from_dict(data, where=str(p))
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, DataIntegrityError | InvalidArgument):
            raise
        msg = f"manifest {p} is missing or has malformed fields ({exc!r}); regenerate it"
        raise DataIntegrityError(msg) from exc
