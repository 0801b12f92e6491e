"""Shard records: what a finished shard holds (range, size, sha256, per-episode hashes).

A record is written next to its shard (``shard-AAAAAAA-BBBBBBB.h5.record.json``) after the
shard has its final name; a shard with a matching record is complete. The manifest is
assembled from the records.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.errors import DataIntegrityError
from nsrmp_bench.storage.atomic import atomic_write_text, fsync_dir
from nsrmp_bench.storage.layout import RECORD_SUFFIX

__all__ = ["CATEGORY_KEYS", "OPTIONAL_CATEGORY_KEYS", "EpisodeEntry", "ShardRecord",
           "atomic_write_text", "fsync_dir"]

CATEGORY_KEYS = ("steps", "objects", "relational", "relation_needed", "phrasing", "template",
                 "phenomenon")
"""The category columns of an episode (``SymbolicEpisode.categories()``)."""

OPTIONAL_CATEGORY_KEYS = ("phenomenon",)
"""Categories only some episodes have (the semantics split's): absent elsewhere, so the
other splits' files, manifests and index columns stay as they were."""


@dataclass(frozen=True)
class EpisodeEntry:
    """One episode of a shard: instance index, id, content hash and categories.

    ``tolerant`` is the tolerant summary of a robot episode
    (:func:`~nsrmp_bench.storage.tolerance.tolerant_summary`), None otherwise.
    """

    index: int
    id: str
    hash: str
    categories: dict[str, Any] = field(default_factory=dict, compare=False)
    tolerant: dict[str, Any] | None = field(default=None, compare=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (categories flattened in)."""
        out = {"index": self.index, "id": self.id, "hash": self.hash, **self.categories}
        if self.tolerant is not None:
            out["tolerant"] = self.tolerant
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> EpisodeEntry:
        """Inverse of :meth:`to_dict`."""
        cats = {k: data[k] for k in CATEGORY_KEYS if k in data}
        tolerant = data.get("tolerant")
        return cls(int(data["index"]), str(data["id"]), str(data["hash"]), cats,
                   dict(tolerant) if isinstance(tolerant, dict) else None)


@dataclass(frozen=True)
class ShardRecord:
    """A complete shard: its file name, index range, byte size, sha256 and episodes."""

    file: str
    start: int
    stop: int
    sha256: str
    bytes: int
    split: str
    episodes: tuple[EpisodeEntry, ...]
    generator: str = ""

    @property
    def count(self) -> int:
        """Number of episodes in the shard."""
        return len(self.episodes)

    def to_dict(self, *, with_episodes: bool = True) -> dict[str, Any]:
        """JSON-able form."""
        out: dict[str, Any] = {
            "file": self.file,
            "index_range": [self.start, self.stop],
            "count": self.count,
            "sha256": self.sha256,
            "bytes": self.bytes,
            "split": self.split,
            "generator": self.generator,
        }
        if with_episodes:
            out["episodes"] = [e.to_dict() for e in self.episodes]
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any], episodes: tuple[EpisodeEntry, ...] | None = None
                  ) -> ShardRecord:
        """Inverse of :meth:`to_dict` (``episodes`` given separately for manifest rows)."""
        start, stop = (int(v) for v in data["index_range"])
        eps = episodes if episodes is not None else tuple(
            EpisodeEntry.from_dict(e) for e in data["episodes"]
        )
        return cls(str(data["file"]), start, stop, str(data["sha256"]), int(data["bytes"]),
                   str(data.get("split", "")), eps, str(data.get("generator", "")))

    def write(self, directory: Path) -> Path:
        """Write the record next to its shard, atomically."""
        path = directory / (self.file + RECORD_SUFFIX)
        atomic_write_text(path, canonical_json(self.to_dict()) + "\n")
        return path

    @classmethod
    def read(cls, path: Path) -> ShardRecord:
        """Read a record file; a damaged one raises :class:`DataIntegrityError`."""
        try:
            return cls.from_dict(json.loads(path.read_text("utf-8")))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            msg = (
                f"shard record {path} is unreadable ({exc}); delete it and the shard next to "
                "it and generate that shard again"
            )
            raise DataIntegrityError(msg) from exc
