"""Writing episodes into HDF5 shards, crash-safely: :func:`shard_writer` picks a strategy.

A :class:`~nsrmp_bench.storage.shard_writer.ShardWriter` writes
``shard-AAAAAAA-BBBBBBB.h5.tmp``, flushes after every episode, and on ``commit`` closes,
fsyncs, renames the file to its final name and then writes its record (``.record.json``).
A killed writer leaves only ``*.tmp`` files, which
:func:`~nsrmp_bench.storage.resume.scan_output` removes. One class per strategy, all
writing the same bytes (``tests/storage`` checks them against the committed shards):

* ``background=False``: :class:`~nsrmp_bench.storage.sync_writer.SyncShardWriter`, in the
  caller's thread;
* ``background=True`` (the default) or ``"thread"``:
  :class:`~nsrmp_bench.storage.sync_writer.ThreadShardWriter`, hashing, compressing and
  writing on a writer thread while the caller makes the next episode;
* ``background="process"``: :class:`~nsrmp_bench.storage.process_writer.ProcessShardWriter`,
  in a child process forked for the shard (a thread where a process cannot fork:
  :func:`writer_mode`).

How each episode becomes an HDF5 group (and why the writers compress the image chunks
themselves) is :mod:`~nsrmp_bench.storage.episode_group`; the measurements behind the
strategies are in the performance page of the docs.
"""

from __future__ import annotations

import os
from typing import Literal

from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.episode_group import write_episode_group
from nsrmp_bench.storage.layout import DATA_WRITER_VERSION
from nsrmp_bench.storage.process_writer import ProcessShardWriter, writer_mode
from nsrmp_bench.storage.records import ShardRecord
from nsrmp_bench.storage.shard_writer import ShardWriter
from nsrmp_bench.storage.sync_writer import SyncShardWriter, ThreadShardWriter

__all__ = ["Background", "ShardWriter", "shard_writer", "write_episode_group", "write_shard",
           "writer_mode"]

Background = bool | Literal["thread", "process"]
"""How a shard writer writes: ``False`` in ``add``, ``True`` or ``"thread"`` on a writer
thread, ``"process"`` in a forked child."""


def shard_writer(
    out_dir: str | os.PathLike[str],
    start: int,
    stop: int,
    *,
    split: str,
    package_version: str = DATA_WRITER_VERSION,
    background: Background = True,
    queue_size: int = 2,
) -> ShardWriter:
    """The writer of the shard of instance indices ``start <= i < stop`` in ``out_dir``,
    for the strategy ``background`` (``queue_size``: how many episodes may wait for a
    writer thread)."""
    if queue_size < 1:
        msg = f"ShardWriter queue_size must be at least 1, got {queue_size}"
        raise InvalidArgument(msg)
    if background not in (True, False, "thread", "process"):
        msg = (f"ShardWriter background must be False, True, 'thread' or 'process', "
               f"got {background!r}")
        raise InvalidArgument(msg)
    if background == "process" and writer_mode() == "process":
        return ProcessShardWriter(out_dir, start, stop, split=split,
                                  package_version=package_version)
    if background:
        return ThreadShardWriter(out_dir, start, stop, split=split,
                                 package_version=package_version, queue_size=queue_size)
    return SyncShardWriter(out_dir, start, stop, split=split, package_version=package_version)


def write_shard(
    out_dir: str | os.PathLike[str],
    start: int,
    episodes: list[Episode] | tuple[Episode, ...],
    *,
    split: str,
    package_version: str = DATA_WRITER_VERSION,
) -> ShardRecord:
    """Write ``episodes`` (instance indices ``start``, ``start+1`` ...) as one shard."""
    if not episodes:
        msg = f"write_shard needs at least one episode for the shard starting at {start}"
        raise InvalidArgument(msg)
    with shard_writer(out_dir, start, start + len(episodes), split=split,
                      package_version=package_version) as w:
        for ep in episodes:
            w.add(ep)
        return w.commit()
