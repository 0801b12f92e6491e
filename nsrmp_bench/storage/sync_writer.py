"""The shard writers of this process: :class:`SyncShardWriter` hashes, compresses and
writes in :meth:`~SyncShardWriter.add`; :class:`ThreadShardWriter` does the same on a
writer thread, in the order episodes were added, while the caller makes the next episode.

Every writer's commit hashes the closed file while another thread fsyncs it
(:func:`~nsrmp_bench.storage.atomic.fsync_hashing`): the commit waits for the longer of
the two, not their sum.
"""

from __future__ import annotations

import json
import os
import queue
import threading
from collections.abc import Callable

import h5py
import numpy as np

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.dsl.program import newest_dsl_version
from nsrmp_bench.episode import SCHEMA_VERSION, Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage import episode_group, h5_objects
from nsrmp_bench.storage.atomic import fsync_hashing
from nsrmp_bench.storage.chunks import Compressed
from nsrmp_bench.storage.hashing import episode_hash
from nsrmp_bench.storage.layout import DATA_WRITER_VERSION, FORMAT, LIBVER, create_group
from nsrmp_bench.storage.prefix_deflate import PrefixDeflater
from nsrmp_bench.storage.records import EpisodeEntry, ShardRecord, fsync_dir
from nsrmp_bench.storage.shard_writer import ShardWriter, remove_partial
from nsrmp_bench.storage.tolerance import tolerant_summary
from nsrmp_bench.vocabulary import vocabulary_dict

__all__ = ["SyncShardWriter", "ThreadShardWriter"]


class SyncShardWriter(ShardWriter):
    """Hashes, compresses and writes each episode in :meth:`add`, then flushes."""

    def __init__(self, out_dir: str | os.PathLike[str], start: int, stop: int, *,
                 split: str, package_version: str = DATA_WRITER_VERSION) -> None:
        super().__init__(out_dir, start, stop, split=split, package_version=package_version)
        self._entries: list[EpisodeEntry] = []
        self._dsl = "dsl-v1"  # the oldest DSL version the shard's programs need
        self._error: BaseException | None = None
        self._deflater = PrefixDeflater()
        self._f: h5py.File | None = h5py.File(self.tmp_path, "w", libver=LIBVER)
        self._f.attrs["format"] = FORMAT
        self._f.attrs["schema_version"] = SCHEMA_VERSION
        self._data = create_group(self._f, "data")

    @property
    def closed(self) -> bool:
        return self._f is None

    def _put(self, episode: Episode, index: int, compressed: Compressed | None) -> None:
        self._write(episode, index, compressed)

    def _write(self, episode: Episode, index: int, compressed: Compressed | None) -> None:
        """Hash and write one episode, its image chunks in ``compressed`` as they are."""
        assert self._f is not None
        ehash = episode_hash(episode)
        episode_group.write_episode_group(self._data, episode, index, ehash,
                                          compressed=compressed, deflater=self._deflater)
        self._f.flush()
        self._dsl = newest_dsl_version((self._dsl, episode.symbolic.program.dsl_version))
        self._entries.append(EpisodeEntry(index, episode.id, ehash,
                                          episode.symbolic.categories(),
                                          tolerant_summary(episode)))

    def raise_error(self) -> None:
        if self._error is not None:
            msg = f"writing shard {self.file} failed: {self._error}"
            if isinstance(self._error, InvalidArgument):  # bad input stays bad input
                raise InvalidArgument(msg) from self._error
            raise RuntimeError(msg) from self._error

    def _finish_writing(self) -> None:
        """Everything added is written (the writer thread waits here)."""
        self.raise_error()

    def commit(self) -> ShardRecord:
        if self._f is None:
            msg = f"shard {self.file} is already committed or aborted"
            raise InvalidArgument(msg)
        try:
            self._finish_writing()
        except BaseException:
            self.abort()
            raise
        f = self._f
        self.check_complete()
        vocab = vocabulary_dict()
        f.attrs["units"] = canonical_json(vocab["units"])
        f.attrs["vocabulary"] = canonical_json(vocab)
        f.attrs["camera"] = self._camera if self._camera is not None else "null"
        f.attrs["split"] = self.split
        generator = ",".join(sorted(set(self._generators)))
        f.attrs["generator"] = generator
        f.attrs["package_version"] = self.package_version
        # the oldest DSL that reads every program of the shard: a shard without the newer
        # operations keeps the bytes it had before they were added
        f.attrs["dsl"] = self._dsl
        f.attrs["index_start"] = np.int64(self.start)
        f.attrs["index_stop"] = np.int64(self.stop)
        f.attrs["num_episodes"] = np.int64(len(self._entries))
        self._data.attrs["total"] = np.int64(len(self._entries))
        # robomimic's mask/<filter key>; a split such as "paper-v2/train" nests
        parts = [p for p in (self.split or "all").split("/") if p not in ("", ".", "..")]
        group = create_group(f, "mask")
        for part in parts[:-1]:
            group = create_group(group, part)
        ids = np.array([e.id for e in self._entries], dtype=h5_objects.STRING)
        group.create_dataset(parts[-1] if parts else "all", data=ids, dtype=h5_objects.STRING,
                             track_times=False)
        rows = [{"id": e.id, "index": e.index, **e.categories} for e in self._entries]
        index = json.dumps(rows, sort_keys=True, separators=(",", ":"), allow_nan=False)
        h5_objects.string_dataset(f.id, "index", index)
        f.close()
        self._f = None
        sha = fsync_hashing(self.tmp_path)
        size = self.tmp_path.stat().st_size
        os.replace(self.tmp_path, self.path)
        fsync_dir(self.out_dir)
        record = ShardRecord(self.file, self.start, self.stop, sha, size, self.split,
                             tuple(self._entries), generator)
        record.write(self.out_dir)
        return record

    def abort(self) -> None:
        try:
            if self._f is not None:
                f, self._f = self._f, None
                f.close()  # on a full disk this fails too; the partial file goes anyway
        finally:
            remove_partial(self.tmp_path)


class ThreadShardWriter(SyncShardWriter):
    """Hashes and writes on a writer thread (at most ``queue_size`` episodes wait for it;
    :meth:`add` returns at once); an error there is raised by the next :meth:`add` or by
    :meth:`commit`.

    A thread shares the GIL with its caller, and PyBullet holds the GIL through each of its
    calls: a generator that spends most of its time in PyBullet leaves the writer thread
    little room (a writer process, :mod:`~nsrmp_bench.storage.process_writer`, does not
    share it)."""

    def __init__(self, out_dir: str | os.PathLike[str], start: int, stop: int, *,
                 split: str, package_version: str = DATA_WRITER_VERSION,
                 queue_size: int = 2) -> None:
        if queue_size < 1:
            msg = f"ShardWriter queue_size must be at least 1, got {queue_size}"
            raise InvalidArgument(msg)
        super().__init__(out_dir, start, stop, split=split, package_version=package_version)
        self._jobs: queue.Queue[Callable[[], None] | None] = queue.Queue(maxsize=queue_size)
        self._thread: threading.Thread | None = threading.Thread(
            target=self._drain, name=f"writer {self.file}", daemon=True)
        self._thread.start()

    def _drain(self) -> None:
        """The writer thread: run the queued jobs in order; after an error, skip the rest."""
        while True:
            job = self._jobs.get()
            if job is None:
                return
            if self._error is None:
                try:
                    job()
                except BaseException as exc:  # re-raised in the caller's thread
                    self._error = exc

    def _put(self, episode: Episode, index: int, compressed: Compressed | None) -> None:
        self._jobs.put(lambda: self._write(episode, index, compressed))

    def _finish_writing(self) -> None:
        """Stop the writer thread once it has written everything queued; re-raise its
        error, if any."""
        if self._thread is not None:
            self._jobs.put(None)
            self._thread.join()
            self._thread = None
        self.raise_error()

    def abort(self) -> None:
        if self._thread is not None:
            self._error = self._error or RuntimeError("aborted")  # skip what is queued
            self._jobs.put(None)
            self._thread.join()
            self._thread = None
        super().abort()
