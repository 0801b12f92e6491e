"""What every shard writer keeps: the index order of its episodes, its file's names, and
commit on a clean exit from its ``with`` block, abort (remove the ``.tmp``) on an error.

The strategies are its subclasses (:mod:`~nsrmp_bench.storage.sync_writer`: in the
caller's thread or on a writer thread; :mod:`~nsrmp_bench.storage.process_writer`: in a
forked child); :func:`nsrmp_bench.storage.writer.shard_writer` picks one.
"""

from __future__ import annotations

import abc
import os
from pathlib import Path
from types import TracebackType

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.chunks import Compressed
from nsrmp_bench.storage.layout import DATA_WRITER_VERSION, TMP_SUFFIX, shard_filename
from nsrmp_bench.storage.records import ShardRecord

__all__ = ["ShardWriter", "remove_partial"]


class ShardWriter(abc.ABC):
    """Writes the episodes of instance indices ``start <= i < stop`` into one shard.

    Use as a context manager; episodes must come in index order (``seed.index`` is the
    instance index). Leaving the block normally commits, an exception aborts (removes the
    ``.tmp``). A committed shard has its final name and a ``.record.json`` next to it.
    Every strategy writes the same bytes.
    """

    def __init__(self, out_dir: str | os.PathLike[str], start: int, stop: int, *,
                 split: str, package_version: str = DATA_WRITER_VERSION) -> None:
        self.out_dir = Path(out_dir)
        self.start, self.stop = start, stop
        self.file = shard_filename(start, stop)
        self.split = split
        self.package_version = package_version
        self.path = self.out_dir / self.file
        self.tmp_path = self.out_dir / (self.file + TMP_SUFFIX)
        self._generators: list[str] = []
        self._camera: str | None = None
        self._next = start
        self.out_dir.mkdir(parents=True, exist_ok=True)  # a bad folder fails here, early

    @property
    @abc.abstractmethod
    def closed(self) -> bool:
        """Whether the shard is committed or aborted."""

    @abc.abstractmethod
    def _put(self, episode: Episode, index: int, compressed: Compressed | None) -> None:
        """Write (or hand over) one admitted episode."""

    @abc.abstractmethod
    def raise_error(self) -> None:
        """Raise what stopped the writing in the background, if anything did."""

    @abc.abstractmethod
    def commit(self) -> ShardRecord:
        """Finish the file, fsync, rename to its final name, write its record."""

    @abc.abstractmethod
    def abort(self) -> None:
        """Close and remove the partial file."""

    @property
    def chunks_compressed_here(self) -> int:
        """How many image chunks the caller compressed itself so far, rather than wait
        for a lagging writer process (0 for the other writers)."""
        return 0

    @property
    def next_index(self) -> int:
        """The instance index the next episode must have."""
        return self._next

    def add(self, episode: Episode, compressed: Compressed | None = None) -> None:
        """Write one episode (then flush), or queue it for the writer thread or process.
        ``compressed`` holds image chunks already through the filters, stored as they are
        (a writer process's parent compresses some for it)."""
        self.raise_error()
        if self.closed:
            msg = f"shard {self.file} is already committed or aborted; open a new ShardWriter"
            raise InvalidArgument(msg)
        index = episode.symbolic.seed.index
        if index != self._next:
            msg = (
                f"shard {self.file} expects instance index {self._next} next, got episode "
                f"{episode.id} with seed.index {index}; add episodes in index order"
            )
            raise InvalidArgument(msg)
        if index >= self.stop:
            msg = f"shard {self.file} covers indices [{self.start}, {self.stop}); got {index}"
            raise InvalidArgument(msg)
        self._put(episode, index, compressed)
        self._generators.append(episode.symbolic.generator)
        if self._camera is None and episode.rendering is not None:
            self._camera = canonical_json(episode.rendering.camera.to_dict())
        self._next += 1

    def check_complete(self) -> None:
        """Raise :class:`InvalidArgument` unless every index of the shard was added."""
        if self._next != self.stop:
            msg = (
                f"shard {self.file} covers indices [{self.start}, {self.stop}) but holds "
                f"{self._next - self.start} episodes; add the missing ones before commit"
            )
            raise InvalidArgument(msg)

    def __enter__(self) -> ShardWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is not None:
            self.abort()
        elif not self.closed:
            self.commit()


def remove_partial(tmp_path: Path) -> None:
    """Remove a shard's partial file; something else in its place (a folder: the writer
    could not open its file there) is not the writer's to remove, and the error that
    stopped the writer is what the caller sees."""
    if tmp_path.is_symlink() or not tmp_path.is_dir():
        tmp_path.unlink(missing_ok=True)
