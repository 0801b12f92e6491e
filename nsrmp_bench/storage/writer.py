"""Writing episodes into HDF5 shards, crash-safely.

A :class:`ShardWriter` writes ``shard-AAAAAAA-BBBBBBB.h5.tmp``, flushes after every
episode, and on :meth:`ShardWriter.commit` closes, fsyncs, renames the file to its final
name and then writes its record (``.record.json``). A killed writer leaves only ``*.tmp``
files, which :func:`~nsrmp_bench.storage.resume.scan_output` removes.

Every writer compresses the image chunks itself with Python's ``zlib`` and stores them
with ``write_direct_chunk`` (:mod:`~nsrmp_bench.storage.chunks`): the filters HDF5 would
apply (byte shuffle for float images, then DEFLATE level 1), so the same bytes on disk,
which ``tests/storage`` checks against the committed shards; it costs less CPU than
HDF5's filter called through h5py (a quarter less at 320x240), and zlib lets go of the
GIL. Each writer learns its shard's background from its first episodes and compresses an
RGB or segmentation image only after the rows it shares with it, resuming a copy of the
background's compressor (:mod:`~nsrmp_bench.storage.prefix_deflate`): the same bytes.

With ``background=True`` (the default) hashing, compressing and writing run on one writer
thread, in the order episodes were added, while the caller makes the next episode.

A thread still shares the GIL with its caller, and PyBullet holds the GIL through each of
its calls: a generator that spends most of its time in PyBullet leaves the writer thread
little room (measured: one worker wrote 27 episodes/s where it generated 57 alone).
``background="process"`` writes in a child process forked for the shard instead (the
synchronous writer's code, so the same bytes): the caller only hands each episode over,
its image arrays through shared memory (:mod:`~nsrmp_bench.storage.handover`) and the
rest over a pipe. When the child lags (both slots hold episodes it has not written yet),
the caller does not just wait: it compresses the image chunks of the episode it is
handing over until a slot is free (:func:`~nsrmp_bench.storage.chunks.precompress`), and
the child stores those as they are, so the work is shared between the two cores. The
shard's last episode is compressed by the caller until the child has released every
slot, since after it the caller would only wait. The caller does not wait for the
child to open the file either: it makes the first episode meanwhile, and the first
:meth:`ShardWriter.add` reports a child that could not. The
child ends with the shard: it commits when told, and aborts
(removes the ``.tmp``) when told to or when the caller's end of the pipe closes (the
caller died); once its record has come, the caller leaves its exit to multiprocessing,
which reaps it when the next writer starts or when asked for its children. A daemonic
process (a Dask worker) cannot have children; there it is a thread (:func:`writer_mode`).

Every writer's commit hashes the closed file while another thread fsyncs it
(:func:`~nsrmp_bench.storage.atomic.fsync_hashing`): the commit waits for the longer of
the two, not their sum.
"""

from __future__ import annotations

import contextlib
import json
import multiprocessing as mp
import os
import queue
import signal
import threading
from collections.abc import Callable, Mapping
from multiprocessing.connection import Connection
from pathlib import Path
from types import TracebackType
from typing import Any, Literal, NoReturn

import h5py
import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.dsl.program import load_signatures
from nsrmp_bench.episode import SCHEMA_VERSION, Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage import h5_objects
from nsrmp_bench.storage.arrays import episode_arrays
from nsrmp_bench.storage.atomic import fsync_hashing
from nsrmp_bench.storage.chunks import (
    Compressed,
    filtered_chunk,
    has_filtered_chunks,
    image_chunks,
    image_datasets,
    precompress,
)
from nsrmp_bench.storage.handover import Handover
from nsrmp_bench.storage.hashing import episode_hash
from nsrmp_bench.storage.layout import (
    DATA_WRITER_VERSION,
    FORMAT,
    LIBVER,
    TMP_SUFFIX,
    check_episode_id,
    create_group,
    shard_filename,
    small_codec,
)
from nsrmp_bench.storage.prefix_deflate import PrefixDeflater
from nsrmp_bench.storage.records import EpisodeEntry, ShardRecord, fsync_dir
from nsrmp_bench.storage.tolerance import tolerant_summary
from nsrmp_bench.vocabulary import vocabulary_dict

__all__ = ["Background", "ShardWriter", "write_episode_group", "write_shard", "writer_mode"]

Background = bool | Literal["thread", "process"]
"""How a :class:`ShardWriter` writes: ``False`` in :meth:`ShardWriter.add`, ``True`` or
``"thread"`` on a writer thread, ``"process"`` in a forked child."""

def _put_image(group: Any, path: str, name: str, arr: NDArray[Any], kw: Mapping[str, Any],
               compressed: Compressed, deflater: PrefixDeflater | None) -> None:
    """An :func:`image_codec` dataset, its chunks compressed here (or taken from
    ``compressed``) and written as they are: the filters HDF5 would apply, so the same
    bytes. ``path`` is the group's path in the episode group."""
    key = f"{path}/{name}"
    if not has_filtered_chunks(kw):  # an empty stack
        h5_objects.dataset(group, name, arr, kw)
        return
    chunks = list(image_chunks(arr, kw))  # refuses other chunk shapes before creating
    ds = h5_objects.empty_dataset(group, name, arr.shape, arr.dtype, kw)
    for k, offset, chunk in chunks:
        ready = compressed.get((key, k))
        ds.write_direct_chunk(offset, ready if ready is not None
                              else filtered_chunk(chunk, kw, deflater))


def write_episode_group(parent: h5py.Group, episode: Episode, index: int, ehash: str, *,
                        compressed: Compressed | None = None,
                        deflater: PrefixDeflater | None = None) -> None:
    """Write one episode as ``parent/<id>`` in the layout of :mod:`~nsrmp_bench.storage.layout`.

    The groups, datasets and attributes are made through :mod:`~nsrmp_bench.storage.
    h5_objects` (h5py's low-level calls, the same bytes as its high-level ones).
    The image chunks are compressed here by Python's zlib (:func:`~nsrmp_bench.storage.
    chunks.filtered_chunk`) and written with ``write_direct_chunk``, not by HDF5's filters
    called through h5py: the same bytes, less CPU (h5py's filter path copies and converts
    on the way), and zlib lets go of the GIL, so a writer thread leaves its caller room.
    ``compressed`` holds chunks already through the filters (:func:`~nsrmp_bench.storage.
    chunks.precompress`), stored as they are. A ``deflater`` (one per shard) compresses
    the rest, resuming after the rows they share with the shard's learnt background (the
    same bytes; :mod:`~nsrmp_bench.storage.prefix_deflate`)."""
    if deflater is not None:
        deflater.next_episode()
    sym = episode.symbolic
    arrays = episode_arrays(episode)
    g = h5_objects.group(parent.id, check_episode_id(sym.id))
    put = h5_objects.attribute
    put(g, "id", sym.id)
    put(g, "index", np.int64(index))
    put(g, "content_hash", ehash)
    put(g, "num_steps", np.int64(sym.num_steps))
    put(g, "num_objects", np.int64(sym.num_objects))
    put(g, "seed", canonical_json(sym.seed.to_dict()))
    put(g, "generator", sym.generator)
    r = episode.rendering
    put(g, "has_rendering", np.bool_(r is not None))
    put(g, "has_images", np.bool_("observations/rgb" in arrays))
    if r is not None:
        put(g, "camera", canonical_json(r.camera.to_dict()))
        put(g, "executor", r.executor)
        # a dataset, not an attribute: robot executors can record more than 64 KiB
        h5_objects.string_dataset(g, "physics", canonical_json(r.physics))

    inputs = h5_objects.group(g, "inputs")
    h5_objects.string_dataset(inputs, "instruction", sym.instruction.text)
    targets = h5_objects.group(g, "targets")
    h5_objects.string_dataset(targets, "symbolic", canonical_json(sym.to_dict()))
    h5_objects.string_dataset(targets, "program", sym.program.text())

    images = image_datasets(arrays)
    if images:
        groups = {"inputs/obs": h5_objects.group(inputs, "obs"),
                  "targets/obs": h5_objects.group(targets, "obs")}
        for path, name, arr, kw in images:
            _put_image(groups[path], path, name, arr, kw, compressed or {}, deflater)
    if r is not None:
        for key in ("boxes_amodal", "boxes_visible"):
            h5_objects.dataset(inputs, key, arrays[f"targets/{key}"][0], small_codec())
        for key in ("poses", "boxes_amodal", "boxes_visible", "visible_fraction",
                    "depth_centre"):
            h5_objects.dataset(targets, key, arrays[f"targets/{key}"], small_codec())
        if r.trajectory is not None:
            robot = h5_objects.group(targets, "robot")
            put(robot, "joint_names", canonical_json(list(r.trajectory.joint_names)))
            for key in ("time", "joint_positions", "ee_pose", "gripper", "step"):
                h5_objects.dataset(robot, key, arrays[f"trajectory/{key}"], small_codec())


class ShardWriter:
    """Writes the episodes of instance indices ``start <= i < stop`` into one shard.

    Use as a context manager; episodes must come in index order (``seed.index`` is the
    instance index). Leaving the block normally commits, an exception aborts (removes the
    ``.tmp``). A committed shard has its final name and a ``.record.json`` next to it.

    ``background=True`` (the default, also ``"thread"``) hashes and writes on a writer
    thread (at most ``queue_size`` episodes wait for it; :meth:`add` returns at once); an
    error there is raised by the next :meth:`add` or by :meth:`commit`.
    ``background="process"`` does the same in a child process forked for the shard (see
    the module doc; a thread where a process cannot fork). ``background=False`` does it
    all in :meth:`add`. All write the same bytes.
    """

    def __init__(
        self,
        out_dir: str | os.PathLike[str],
        start: int,
        stop: int,
        *,
        split: str,
        package_version: str = DATA_WRITER_VERSION,
        background: Background = True,
        queue_size: int = 2,
    ) -> None:
        if queue_size < 1:
            msg = f"ShardWriter queue_size must be at least 1, got {queue_size}"
            raise InvalidArgument(msg)
        self.out_dir = Path(out_dir)
        self.start, self.stop = start, stop
        self.file = shard_filename(start, stop)
        self.split = split
        self.package_version = package_version
        self.path = self.out_dir / self.file
        self.tmp_path = self.out_dir / (self.file + TMP_SUFFIX)
        self._entries: list[EpisodeEntry] = []
        self._generators: list[str] = []
        self._camera: str | None = None
        self._next = start
        if background not in (True, False, "thread", "process"):
            msg = (f"ShardWriter background must be False, True, 'thread' or 'process', "
                   f"got {background!r}")
            raise InvalidArgument(msg)
        self._child: _Child | None = None
        self._deflater: PrefixDeflater | None = None  # where this writer compresses
        self._f: h5py.File | None = None
        self._jobs: queue.Queue[Callable[[], None] | None] | None = None
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self.out_dir.mkdir(parents=True, exist_ok=True)  # a bad folder fails here, early
        if background == "process" and writer_mode() == "process":
            self._child = _Child(self.tmp_path, (os.fspath(out_dir), start, stop, split,
                                                 package_version))
            return
        self._deflater = PrefixDeflater()
        self._f = h5py.File(self.tmp_path, "w", libver=LIBVER)
        self._f.attrs["format"] = FORMAT
        self._f.attrs["schema_version"] = SCHEMA_VERSION
        self._data = create_group(self._f, "data")
        if background:
            self._jobs = queue.Queue(maxsize=queue_size)
            self._thread = threading.Thread(target=self._drain, name=f"writer {self.file}",
                                            daemon=True)
            self._thread.start()

    def _drain(self) -> None:
        """The writer thread: run the queued jobs in order; after an error, skip the rest."""
        assert self._jobs is not None
        while True:
            job = self._jobs.get()
            if job is None:
                return
            if self._error is None:
                try:
                    job()
                except BaseException as exc:  # re-raised in the caller's thread
                    self._error = exc

    def _wait(self) -> None:
        """Stop the writer thread once it has written everything queued; re-raise its
        error, if any."""
        if self._thread is not None and self._jobs is not None:
            self._jobs.put(None)
            self._thread.join()
            self._thread = None
        self._raise_error()

    def _raise_error(self) -> None:
        if self._child is not None:
            self._child.raise_error()
        if self._error is not None:
            msg = f"writing shard {self.file} failed: {self._error}"
            if isinstance(self._error, InvalidArgument):  # bad input stays bad input
                raise InvalidArgument(msg) from self._error
            raise RuntimeError(msg) from self._error

    def _write(self, episode: Episode, index: int, compressed: Compressed | None = None) -> None:
        """Hash and write one episode (on the writer thread when in the background), its
        image chunks in ``compressed`` as they are."""
        assert self._f is not None
        ehash = episode_hash(episode)
        write_episode_group(self._data, episode, index, ehash, compressed=compressed,
                            deflater=self._deflater)
        self._f.flush()
        self._entries.append(EpisodeEntry(index, episode.id, ehash,
                                          episode.symbolic.categories(),
                                          tolerant_summary(episode)))

    @property
    def chunks_compressed_here(self) -> int:
        """How many image chunks the caller compressed itself so far, rather than wait
        for a lagging writer process (0 for the other writers)."""
        return self._child.chunks_compressed if self._child is not None else 0

    @property
    def next_index(self) -> int:
        """The instance index the next episode must have."""
        return self._next

    def add(self, episode: Episode) -> None:
        """Write one episode (then flush), or queue it for the writer thread or process."""
        self._add(episode, None)

    def _add(self, episode: Episode, compressed: Compressed | None) -> None:
        """:meth:`add`; the synchronous writer of a writer process also takes the image
        chunks its parent compressed (``compressed``)."""
        self._raise_error()
        if self._f is None and (self._child is None or self._child.closed):
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
        if self._child is not None:  # its own caller compresses for it (compressed is None)
            self._child.add(episode, last=index == self.stop - 1)
        elif self._jobs is not None:
            self._jobs.put(lambda: self._write(episode, index, compressed))
        else:
            self._write(episode, index, compressed)
        self._generators.append(episode.symbolic.generator)
        if self._camera is None and episode.rendering is not None:
            self._camera = canonical_json(episode.rendering.camera.to_dict())
        self._next += 1

    def commit(self) -> ShardRecord:
        """Finish the file, fsync, rename to its final name, write its record."""
        if self._child is not None and not self._child.closed:
            try:
                self._check_complete()
            except InvalidArgument:
                self._child.abort()
                raise
            return self._child.commit()
        if self._f is None:
            msg = f"shard {self.file} is already committed or aborted"
            raise InvalidArgument(msg)
        try:
            self._wait()
        except BaseException:
            self.abort()
            raise
        f = self._f
        self._check_complete()
        vocab = vocabulary_dict()
        f.attrs["units"] = canonical_json(vocab["units"])
        f.attrs["vocabulary"] = canonical_json(vocab)
        f.attrs["camera"] = self._camera if self._camera is not None else "null"
        f.attrs["split"] = self.split
        generator = ",".join(sorted(set(self._generators)))
        f.attrs["generator"] = generator
        f.attrs["package_version"] = self.package_version
        f.attrs["dsl"] = str(load_signatures().get("version", ""))
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

    def _check_complete(self) -> None:
        if self._next != self.stop:
            msg = (
                f"shard {self.file} covers indices [{self.start}, {self.stop}) but holds "
                f"{self._next - self.start} episodes; add the missing ones before commit"
            )
            raise InvalidArgument(msg)

    def abort(self) -> None:
        """Close and remove the partial file."""
        if self._child is not None:
            self._child.abort()
        if self._thread is not None and self._jobs is not None:
            self._error = self._error or RuntimeError("aborted")  # skip what is queued
            self._jobs.put(None)
            self._thread.join()
            self._thread = None
        if self._f is not None:
            self._f.close()
            self._f = None
        _remove_partial(self.tmp_path)

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
        elif self._f is not None or (self._child is not None and not self._child.closed):
            self.commit()


def _remove_partial(tmp_path: Path) -> None:
    """Remove a shard's partial file; something else in its place (a folder: the writer
    could not open its file there) is not the writer's to remove, and the error that
    stopped the writer is what the caller sees."""
    if tmp_path.is_symlink() or not tmp_path.is_dir():
        tmp_path.unlink(missing_ok=True)


def writer_mode() -> Literal["process", "thread"]:
    """What ``background="process"`` gives in this process: ``"process"`` where it can
    fork a child (POSIX, and not itself a daemonic process such as a Dask worker),
    else ``"thread"``."""
    if "fork" not in mp.get_all_start_methods() or mp.current_process().daemon:
        return "thread"
    return "process"


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
        self._error: tuple[bool, str] | None = None
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
                                    "without a word"))
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
        _remove_partial(self.tmp_path)

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
            invalid, text = self._error
            msg = f"writing shard {self.file} failed: {text}"
            if not self.closed:
                self.abort()
            if invalid:  # bad input stays bad input
                raise InvalidArgument(msg)
            raise RuntimeError(msg)


def _child_main(episodes: Connection, parents_end: Connection, answer: Connection,
                args: tuple[str, int, int, str, str], handover: Handover) -> None:
    """The forked writer: a synchronous :class:`ShardWriter` fed from the pipe."""
    parents_end.close()  # so that the parent's death reads as the end of the pipe
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C: the parent aborts the shard
    out_dir, start, stop, split, version = args
    writer: ShardWriter | None = None
    try:
        writer = ShardWriter(out_dir, start, stop, split=split, package_version=version,
                             background=False)
        answer.send(("open", None))
        while True:
            try:
                kind, item = episodes.recv()
            except EOFError:  # the parent died or gave up: nothing half-written stays
                writer.abort()
                return
            if kind == "add":
                writer._add(*item)
            elif kind == "shared":  # its arrays are views of a slot, freed once written:
                # the writer is synchronous and keeps no array of what it wrote
                writer._add(*handover.unpack(item))
                handover.release()
            elif kind == "commit":
                answer.send(("record", writer.commit()))
                return
            else:
                writer.abort()
                return
    except BaseException as exc:  # told to the parent, which raises it
        if writer is not None:
            writer.abort()
        answer.send(("error", (isinstance(exc, InvalidArgument), f"{exc}")))


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
    with ShardWriter(out_dir, start, start + len(episodes), split=split,
                     package_version=package_version) as w:
        for ep in episodes:
            w.add(ep)
        return w.commit()
