"""The shard writer in a forked child process (``background="process"``).

A thread still shares the GIL with its caller, and PyBullet holds the GIL through each of
its calls: a generator that spends most of its time in PyBullet leaves a writer thread
little room. :class:`ProcessShardWriter` writes in a child process forked for the shard
instead (a :class:`~nsrmp_bench.storage.sync_writer.SyncShardWriter` there, so the same
bytes): the caller only hands each episode over, its image arrays through shared memory
(:mod:`~nsrmp_bench.storage.handover`) and the rest over a pipe. When the child lags (both
slots hold episodes it has not written yet), the caller does not just wait: it compresses
the image chunks of the episode it is handing over until a slot is free
(:func:`~nsrmp_bench.storage.chunks.precompress`), and the child stores those as they
are, so the work is shared between the two cores. The shard's last episode is compressed
by the caller until the child has released every slot, since after it the caller would
only wait. The caller does not wait for the child to open the file either: it makes the
first episode meanwhile, and the first :meth:`~ProcessShardWriter.add` reports a child
that could not. The child ends with the shard: it commits when told, and aborts (removes
the ``.tmp``) when told to or when the caller's end of the pipe closes (the caller died);
once its record has come, the caller leaves its exit to multiprocessing, which reaps it
when the next writer starts or when asked for its children. A daemonic process (a Dask
worker) cannot have children; there :func:`writer_mode` says ``"thread"``.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import signal
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any, Literal, NoReturn

from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.arrays import episode_arrays
from nsrmp_bench.storage.chunks import Compressed, precompress
from nsrmp_bench.storage.disk_faults import DISK_FAULT_ERRNOS
from nsrmp_bench.storage.handover import Handover
from nsrmp_bench.storage.layout import DATA_WRITER_VERSION, TMP_SUFFIX
from nsrmp_bench.storage.prefix_deflate import PrefixDeflater
from nsrmp_bench.storage.records import ShardRecord
from nsrmp_bench.storage.shard_writer import ShardWriter, remove_partial
from nsrmp_bench.storage.sync_writer import SyncShardWriter

__all__ = ["ProcessShardWriter", "writer_mode"]


def writer_mode() -> Literal["process", "thread"]:
    """What ``background="process"`` gives in this process: ``"process"`` where it can
    fork a child (POSIX, and not itself a daemonic process such as a Dask worker),
    else ``"thread"``."""
    if "fork" not in mp.get_all_start_methods() or mp.current_process().daemon:
        return "thread"
    return "process"


class ProcessShardWriter(ShardWriter):
    """Writes the shard in a forked child (see the module); only where
    :func:`writer_mode` is ``"process"``."""

    def __init__(self, out_dir: str | os.PathLike[str], start: int, stop: int, *,
                 split: str, package_version: str = DATA_WRITER_VERSION) -> None:
        super().__init__(out_dir, start, stop, split=split, package_version=package_version)
        self._child = _Child(self.tmp_path, (os.fspath(out_dir), start, stop, split,
                                             package_version))

    @property
    def closed(self) -> bool:
        return self._child.closed

    @property
    def chunks_compressed_here(self) -> int:
        return self._child.chunks_compressed

    def _put(self, episode: Episode, index: int, compressed: Compressed | None) -> None:
        # the caller compresses for its child itself, while the child lags
        self._child.add(episode, last=index == self.stop - 1)

    def raise_error(self) -> None:
        self._child.raise_error()

    def commit(self) -> ShardRecord:
        if self._child.closed:
            msg = f"shard {self.file} is already committed or aborted"
            raise InvalidArgument(msg)
        try:
            self.check_complete()
        except InvalidArgument:
            self._child.abort()
            raise
        return self._child.commit()

    def abort(self) -> None:
        self._child.abort()
        remove_partial(self.tmp_path)


class _Child:
    """The parent's end of a shard written in a forked child (``background="process"``).

    Each episode goes over as (episode, the image chunks compressed here) with its large
    arrays in one of two shared slots (a :class:`Handover`) and the rest over a one-way
    pipe; an episode too large for a slot goes whole over the pipe. While both slots hold
    episodes the child has not written, the parent compresses chunks of the next episode
    (as many as still fit its slot) until one is free, then waits if it must. The child
    answers when it has opened the file and once at the end: the record, or the error
    that stopped it."""

    def __init__(self, tmp_path: Path, args: tuple[str, int, int, str, str]) -> None:
        """``args``: the child's ShardWriter's (out_dir, start, stop, split, version);
        ``tmp_path``: the file it writes until it commits."""
        ctx = mp.get_context("fork")
        self._episodes_r, self._episodes_w = ctx.Pipe(duplex=False)
        self._answer_r, answer_w = ctx.Pipe(duplex=False)
        self.tmp_path = tmp_path
        self.file = tmp_path.name.removesuffix(TMP_SUFFIX)
        self._handover = Handover(ctx)
        self._proc = ctx.Process(
            target=_child_main, name=f"writer {self.file}", daemon=True,
            args=(self._episodes_r, self._episodes_w, answer_w, args, self._handover))
        self._proc.start()
        answer_w.close()  # the child's; the parent keeps the reading end
        self._episodes_r.close()
        self.closed = False
        self.chunks_compressed = 0  # image chunks compressed here while the child lagged
        self._deflater = PrefixDeflater()  # the caller's own, for the chunks it compresses
        self._error: tuple[bool, str, int | None] | None = None
        # the child's "open" is read when the first episode is handed over (or at commit),
        # not here: the caller makes that episode while the child opens the file
        self._opened = False

    def _answer(self) -> tuple[str, Any]:
        """The child's next message; a child that died without one is an error."""
        try:
            msg: tuple[str, Any] = self._answer_r.recv()
        except EOFError:
            self._proc.join()
            msg = ("error", (False, f"the writer process exited ({self._proc.exitcode}) "
                                    "without a word", None))
        if msg[0] == "error":
            self._error = msg[1]
        elif msg[0] == "open":
            self._opened = True
        return msg

    def _open(self) -> None:
        """Wait for the child to say it has opened the file, or raise what stopped it."""
        if (not self._opened and not self.closed and self._error is None
                and self._answer()[0] != "open"):
            self._failed()
        self.raise_error()

    def add(self, episode: Episode, *, last: bool = False) -> None:
        """Hand ``episode`` over. While the child lags (both slots hold episodes it has
        not written), compress this episode's image chunks here rather than wait, until a
        slot is free: the child stores those as they are (the same bytes). The shard's
        ``last`` episode is compressed here until the child has released every slot (has
        written the episodes before it, but one too large for a slot, which went by the
        pipe: a matter of speed only): after it the caller would only wait for the commit."""
        self._open()
        compressed: Compressed = {}
        ready = self._handover.idle if last else self._handover.free
        if not ready():
            try:
                arrays = episode_arrays(episode)
            except InvalidArgument:  # the child refuses it, as when it does not lag
                arrays = {}
            compressed = precompress(  # as many as still fit the slot beside the arrays
                arrays, until=lambda: ready() or not self._proc.is_alive(),
                max_bytes=self._handover.room(a.nbytes for a in arrays.values()),
                deflater=self._deflater)
        item = (episode, compressed)
        try:
            packed = self._handover.pack(item, self._alive)
            self._episodes_w.send(("add", item) if packed is None else ("shared", packed))
        except (BrokenPipeError, ConnectionResetError):
            self._stopped()
        self.chunks_compressed += len(compressed)

    def _alive(self) -> None:
        """Raise the child's error if it has stopped (called while waiting for a slot)."""
        if not self._proc.is_alive() or self._answer_r.poll():
            self._stopped()

    def _stopped(self) -> NoReturn:
        """The child stopped early: read its error, reap it and raise the error."""
        self._answer()
        self._failed()

    def _failed(self) -> NoReturn:
        """The child stopped (its last message read): reap it and raise its error."""
        self._finish()
        self.raise_error()
        msg = f"writing shard {self.file} failed: the writer process stopped early"
        raise RuntimeError(msg)  # _answer always records an error; kept as a guard

    def commit(self) -> ShardRecord:
        self._open()
        with contextlib.suppress(BrokenPipeError, ConnectionResetError):
            self._episodes_w.send(("commit", None))
        msg = self._answer()
        # with the record the shard is on disk and the child only exits: it is reaped by
        # multiprocessing (the next writer's start, or at exit), not waited for here
        self._finish(reap=msg[0] != "record")
        self.raise_error()
        record: ShardRecord = msg[1]
        return record

    def abort(self) -> None:
        if self.closed:
            return
        with contextlib.suppress(BrokenPipeError, ConnectionResetError):
            self._episodes_w.send(("abort", None))
        self._finish()
        remove_partial(self.tmp_path)

    def _finish(self, *, reap: bool = True) -> None:
        self._episodes_w.close()
        if reap:
            self._proc.join()
        self._answer_r.close()
        self._handover.close()
        self.closed = True

    def raise_error(self) -> None:
        if self._error is None and not self.closed and self._answer_r.poll():
            self._answer()
        if self._error is not None:
            invalid, text, code = self._error
            msg = f"writing shard {self.file} failed: {text}"
            if not self.closed:
                self.abort()
            if invalid:  # bad input stays bad input
                raise InvalidArgument(msg)
            if code in DISK_FAULT_ERRNOS:  # a full disk stays a full disk (the CLI says so)
                raise OSError(code, msg, str(self.tmp_path))
            raise RuntimeError(msg)


def _child_main(episodes: Connection, parents_end: Connection, answer: Connection,
                args: tuple[str, int, int, str, str], handover: Handover) -> None:
    """The forked writer: a :class:`SyncShardWriter` fed from the pipe."""
    parents_end.close()  # so that the parent's death reads as the end of the pipe
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C: the parent aborts the shard
    out_dir, start, stop, split, version = args
    writer: SyncShardWriter | None = None
    try:
        writer = SyncShardWriter(out_dir, start, stop, split=split, package_version=version)
        answer.send(("open", None))
        while True:
            try:
                kind, item = episodes.recv()
            except EOFError:  # the parent died or gave up: nothing half-written stays
                writer.abort()
                return
            if kind == "add":
                writer.add(*item)
            elif kind == "shared":  # its arrays are views of a slot, freed once written:
                # the writer is synchronous and keeps no array of what it wrote
                writer.add(*handover.unpack(item))
                handover.release()
            elif kind == "commit":
                answer.send(("record", writer.commit()))
                return
            else:
                writer.abort()
                return
    except BaseException as exc:  # told to the parent, which raises it
        if writer is not None:  # on a full disk closing fails too: the first error counts
            with contextlib.suppress(Exception):
                writer.abort()
        code = exc.errno if isinstance(exc, OSError) else None
        answer.send(("error", (isinstance(exc, InvalidArgument), f"{exc}", code)))
