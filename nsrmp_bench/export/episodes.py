"""The parts of a generated split and their episodes, for the exporters."""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.manifest import read_manifest
from nsrmp_bench.storage.split_root import split_root_parts

__all__ = ["PartData", "split_parts"]


@dataclass(frozen=True)
class PartData:
    """One generated part: its folder, split id, part name and episode count."""

    path: Path
    split: str
    part: str
    count: int

    def episodes(self, *, images: bool = True) -> Iterator[Episode]:
        """The part's episodes in order."""
        from nsrmp_bench.storage import open as open_storage

        with open_storage(self.path) as collection:
            for i in range(len(collection)):
                yield collection.episode(i, images=images)


def split_parts(data: str | os.PathLike[str]) -> list[PartData]:
    """The parts under ``data`` (a split root, or one part folder); all of one split."""
    src = Path(data)
    if not src.is_dir():
        msg = f"{str(src)!r} is not a folder; give a generated split (or part) directory"
        raise InvalidArgument(msg)
    dirs = [src / p for p in split_root_parts(src)] or [src]
    out: list[PartData] = []
    for d in dirs:
        if not (d / "manifest.json").is_file():
            msg = (f"{str(d)!r} holds no manifest.json; give a generated split (or part) "
                   "directory, e.g. the --out of nsrmp-bench generate")
            raise InvalidArgument(msg)
        manifest = read_manifest(d)
        split, _, part = manifest.split.partition("/")
        count = sum(len(s.episodes) for s in manifest.shards)
        out.append(PartData(d, split, part or d.name, count))
    splits = sorted({p.split for p in out})
    if len(splits) > 1:
        msg = f"{str(src)!r} mixes splits {splits}; export one split at a time"
        raise InvalidArgument(msg)
    return out
