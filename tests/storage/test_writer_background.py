"""The writer thread and the writer process write the bytes of the synchronous writer and of
the committed shards (every writer compresses its image chunks with zlib and writes them
directly, as HDF5's filters would); chunks compressed by the caller are stored as given;
an error or a dead caller leaves no file."""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import multiprocessing as mp
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

pytest.importorskip("pybullet")

from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage import chunks as chunks_module
from nsrmp_bench.storage import episode_group as episode_group_module
from nsrmp_bench.storage import open as open_part
from nsrmp_bench.storage import process_writer as process_writer_module
from nsrmp_bench.storage.arrays import episode_arrays
from nsrmp_bench.storage.chunks import filtered_chunk, image_chunks, image_datasets, precompress
from nsrmp_bench.storage.handover import Handover, Packed
from nsrmp_bench.storage.records import ShardRecord
from nsrmp_bench.storage.writer import Background, ShardWriter, shard_writer, writer_mode


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _write_in_process(out: Path, episodes: list[Episode]) -> tuple[ShardWriter, ShardRecord]:
    """``episodes`` written by a writer process as one shard: the writer and its record."""
    with shard_writer(out, 0, len(episodes), split="smoke-v2/test", background="process") as w:
        for ep in episodes:
            w.add(ep)
        return w, w.commit()


def test_background_writer_writes_the_bytes_of_the_synchronous_one(
    smoke_v2_test: Path, tmp_path: Path
) -> None:
    with open_part(smoke_v2_test) as part:
        episodes = [part.episode(i) for i in range(len(part))]
    shas: dict[Background, tuple[str, str, list[str]]] = {}
    for background in (False, True, "process"):
        out = tmp_path / f"background-{background}"
        with shard_writer(out, 0, len(episodes), split="smoke-v2/test",
                         background=background, queue_size=1) as w:
            for ep in episodes:
                w.add(ep)
            record = w.commit()
        shas[background] = (_sha(out / record.file), record.sha256,
                            [e.hash for e in record.episodes])
    assert shas[True] == shas[False] == shas["process"]
    # and all are the shard the generator made
    committed = next(smoke_v2_test.glob("shard-*.h5"))
    assert shas[True][0] == _sha(committed)


def _slow_down_the_writer(monkeypatch: pytest.MonkeyPatch, seconds: float = 0.1) -> None:
    """Every episode written ``seconds`` late (a writer process forked afterwards inherits
    it)."""
    write = episode_group_module.write_episode_group

    def slow(*args: Any, **kwargs: Any) -> None:
        time.sleep(seconds)
        write(*args, **kwargs)

    monkeypatch.setattr(episode_group_module, "write_episode_group", slow)


def test_a_caller_that_compresses_for_a_lagging_writer_process_writes_the_same_bytes(
    smoke_v2_test: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A writer process slowed down (the fork inherits the patch) lags behind a caller
    with episodes at hand: the caller compresses image chunks while it waits for a slot,
    the child stores them as they are, and the shard is the committed one."""
    with open_part(smoke_v2_test) as part:
        episodes = [part.episode(i) for i in range(len(part))]
    _slow_down_the_writer(monkeypatch)
    w, record = _write_in_process(tmp_path, episodes)
    # from the third episode on both slots are full when it comes (the child sleeps 0.1 s
    # an episode), so the caller compresses for nearly every one; the total is what holds
    assert w.chunks_compressed_here >= len(episodes) - 2
    assert _sha(tmp_path / record.file) == _sha(next(smoke_v2_test.glob("shard-*.h5")))


def test_the_caller_compresses_the_last_episode_while_the_child_writes_the_one_before(
    smoke_v2_test: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With two episodes a slot is always free, so only the rule for a shard's last
    episode makes the caller compress: the child still sleeps over the first one, and
    after the last the caller would only wait for the commit."""
    with open_part(smoke_v2_test) as part:
        episodes = [part.episode(i) for i in range(2)]
    _slow_down_the_writer(monkeypatch, 1.0)  # time enough for ~9 chunks on a loaded machine
    w, record = _write_in_process(tmp_path, episodes)
    last = sum(1 for _, _, arr, kw in image_datasets(episode_arrays(episodes[1]))
               for _ in image_chunks(arr, kw))
    assert w.chunks_compressed_here == last > 0
    with shard_writer(tmp_path / "sync", 0, 2, split="smoke-v2/test", background=False) as s:
        for ep in episodes:
            s.add(ep)
        expected = s.commit()
    assert _sha(tmp_path / record.file) == _sha(tmp_path / "sync" / expected.file)


def test_a_writer_process_that_cannot_open_its_file_fails_the_first_add(
    smoke_v2_test: Path, tmp_path: Path
) -> None:
    """The caller does not wait for the child to open the file (it makes the first episode
    meanwhile); a child that could not is reported by the first add, naming the shard."""
    with open_part(smoke_v2_test) as part:
        first = part.episode(0)
    (tmp_path / "shard-0000000-0000002.h5.tmp").mkdir()  # where the child's file must go
    w = shard_writer(tmp_path, 0, 2, split="smoke-v2/test", background="process")
    with pytest.raises(RuntimeError, match=r"writing shard shard-0000000-0000002\.h5 failed"):
        w.add(first)
    w.abort()
    assert not list(tmp_path.glob("*.h5"))


def test_a_committed_writer_process_is_reaped(smoke_v2_test: Path, tmp_path: Path) -> None:
    """commit returns with the record, without waiting for the child to exit; the child
    is still reaped (multiprocessing does it when asked for its children, or when the
    next writer starts) and exited cleanly."""
    with open_part(smoke_v2_test) as part:
        first = part.episode(0)
    w = shard_writer(tmp_path, 0, 1, split="smoke-v2/test", background="process")
    assert w._child is not None
    proc = w._child._proc
    w.add(first)
    w.commit()
    deadline = time.monotonic() + 20.0
    while proc in mp.active_children():  # each call reaps the children that have exited
        assert time.monotonic() < deadline, "the committed writer process did not exit"
        time.sleep(0.01)
    assert proc.exitcode == 0


def test_the_chunks_a_caller_compresses_reach_the_file_through_the_writer_process(
    smoke_v2_test: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The caller's chunks, marked by another DEFLATE level after the child was forked (so
    only the caller marks), are in the file: as many as it says it compressed."""
    with open_part(smoke_v2_test) as part:
        episodes = [part.episode(i) for i in range(len(part))]
    _slow_down_the_writer(monkeypatch)
    with shard_writer(tmp_path, 0, len(episodes), split="smoke-v2/test",
                     background="process") as w:
        monkeypatch.setattr(chunks_module, "filtered_chunk",
                            lambda chunk, kw, deflater=None: filtered_chunk(
                                chunk, {**kw, "compression_opts": 9}, deflater))
        for ep in episodes:
            w.add(ep)
        record = w.commit()
    monkeypatch.undo()
    marked = 0
    with h5py.File(tmp_path / record.file) as f:
        for ep in episodes:
            group = f["data"][ep.id]
            for path, name, arr, kw in image_datasets(episode_arrays(ep)):
                ds = group[f"{path}/{name}"]
                np.testing.assert_array_equal(ds[()], arr)
                for _, offset, chunk in image_chunks(arr, kw):
                    data = ds.id.read_direct_chunk(offset)[1]
                    if data != filtered_chunk(chunk, kw):
                        assert data == filtered_chunk(chunk, {**kw, "compression_opts": 9})
                        marked += 1
    assert marked == w.chunks_compressed_here > 0


def test_an_episode_with_some_chunks_compressed_beforehand_has_the_same_bytes(
    smoke_v2_test: Path, tmp_path: Path
) -> None:
    """Chunks given compressed are stored as they are, the rest are compressed by the
    writer: the same bytes as the committed shard, with a different split per episode
    (episode k: its first k chunks given)."""
    with open_part(smoke_v2_test) as part:
        episodes = [part.episode(i) for i in range(len(part))]
    out = tmp_path / "mixed"
    with shard_writer(out, 0, len(episodes), split="smoke-v2/test", background=False) as w:
        for k, ep in enumerate(episodes):
            done = iter(range(10**6))
            # episode k: its first k chunks (all of them for the later episodes) given
            compressed = precompress(episode_arrays(ep), until=lambda k=k, d=done: next(d) >= k)
            assert len(compressed) == min(k, 3 * ep.symbolic.num_steps + 3)
            w.add(ep, compressed)
        record = w.commit()
    assert _sha(out / record.file) == _sha(next(smoke_v2_test.glob("shard-*.h5")))


def test_chunks_given_compressed_are_the_chunks_stored(smoke_v2_test: Path, tmp_path: Path) -> None:
    """Given chunks marked by another DEFLATE level (the same pixels, other bytes) are the
    stored ones, exactly those, and the images read back unchanged."""
    with open_part(smoke_v2_test) as part:
        episode = part.episode(len(part) - 1)
    arrays = episode_arrays(episode)
    given: dict[tuple[str, int], np.ndarray[Any, Any]] = {}
    for path, name, arr, kw in image_datasets(arrays):
        for k, _, chunk in image_chunks(arr, kw):
            if (len(given) + k) % 2 == 0:  # every other chunk, in every dataset
                marked = filtered_chunk(chunk, {**kw, "compression_opts": 9})
                given[(f"{path}/{name}", k)] = np.frombuffer(marked, np.uint8)
    index = episode.symbolic.seed.index
    with shard_writer(tmp_path, index, index + 1, split="smoke-v2/test", background=False) as w:
        w.add(episode, given)
        record = w.commit()
    stored = 0
    with h5py.File(tmp_path / record.file) as f:
        group = f["data"][episode.id]
        for path, name, arr, kw in image_datasets(arrays):
            ds = group[f"{path}/{name}"]
            np.testing.assert_array_equal(ds[()], arr)
            for k, offset, chunk in image_chunks(arr, kw):
                _, data = ds.id.read_direct_chunk(offset)
                mark = given.get((f"{path}/{name}", k))
                if mark is None:
                    assert data == filtered_chunk(chunk, kw)
                else:
                    assert data == mark.tobytes()
                    stored += 1
    assert stored == len(given) > 0


def test_an_error_on_the_writer_thread_surfaces_and_leaves_no_file(
    smoke_v2_test: Path, tmp_path: Path
) -> None:
    with open_part(smoke_v2_test) as part:
        first = part.episode(0)
    w = shard_writer(tmp_path, 0, 1, split="smoke-v2/test")
    w._data.create_group(first.id)  # the writer thread will find the episode's name taken
    w.add(first)
    with pytest.raises(RuntimeError, match=r"writing shard shard-0000000-0000001\.h5 failed"):
        w.commit()
    assert not list(tmp_path.glob("*.h5*"))


def test_queue_size_must_be_positive(tmp_path: Path) -> None:
    with pytest.raises(InvalidArgument, match="queue_size must be at least 1, got 0"):
        shard_writer(tmp_path, 0, 1, split="x/test", queue_size=0)


def test_an_error_in_the_writer_process_surfaces_and_leaves_no_file(
    smoke_v2_test: Path, tmp_path: Path
) -> None:
    with open_part(smoke_v2_test) as part:
        first, second = part.episode(0), part.episode(1)
    # the second episode under the first one's id: the child finds the name taken
    clash = dataclasses.replace(second, symbolic=dataclasses.replace(
        second.symbolic, id=first.symbolic.id))
    w = shard_writer(tmp_path, 0, 2, split="smoke-v2/test", background="process")
    w.add(first)
    with pytest.raises((RuntimeError, InvalidArgument),
                       match=r"writing shard shard-0000000-0000002\.h5 failed"):
        w.add(clash)
        w.commit()
    w.abort()
    assert not list(tmp_path.glob("*.h5*"))


def test_a_writer_process_that_fails_early_stops_its_caller_without_a_hang(
    smoke_v2_test: Path, tmp_path: Path
) -> None:
    """The child fails on the second episode while the caller goes on handing episodes
    over: with two shared slots, the caller soon waits for a slot the child will never
    free, and must be told instead of waiting for ever."""
    with open_part(smoke_v2_test) as part:
        episodes = [part.episode(i) for i in range(8)]
    clash = dataclasses.replace(episodes[1], symbolic=dataclasses.replace(
        episodes[1].symbolic, id=episodes[0].symbolic.id))
    w = shard_writer(tmp_path, 0, 8, split="smoke-v2/test", background="process")
    start = time.monotonic()
    with pytest.raises((RuntimeError, InvalidArgument),
                       match=r"writing shard shard-0000000-0000008\.h5 failed"):
        for ep in [episodes[0], clash, *episodes[2:]]:
            w.add(ep)
        w.commit()
    assert time.monotonic() - start < 30.0
    w.abort()
    assert not list(tmp_path.glob("*.h5*"))


def test_episodes_too_large_for_the_shared_slots_go_by_the_pipe_with_the_same_bytes(
    smoke_v2_test: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with open_part(smoke_v2_test) as part:
        episodes = [part.episode(i) for i in range(len(part))]
    small = functools.partial(Handover, slot_bytes=64 * 1024)  # an episode is ~1.4 MB
    monkeypatch.setattr(process_writer_module, "Handover", small)
    packed: list[bool] = []
    pack = Handover.pack

    def spy(self: Handover, obj: object, alive: Callable[[], None]) -> Packed | None:
        out = pack(self, obj, alive)
        packed.append(out is not None)
        return out

    monkeypatch.setattr(Handover, "pack", spy)
    _, record = _write_in_process(tmp_path, episodes)
    assert packed == [False] * len(episodes)  # every one went whole by the pipe
    assert _sha(tmp_path / record.file) == _sha(next(smoke_v2_test.glob("shard-*.h5")))


def test_a_short_shard_in_the_writer_process_is_refused_and_removed(
    smoke_v2_test: Path, tmp_path: Path
) -> None:
    with open_part(smoke_v2_test) as part:
        first = part.episode(0)
    w = shard_writer(tmp_path, 0, 2, split="smoke-v2/test", background="process")
    w.add(first)
    with pytest.raises(InvalidArgument, match="holds 1 episodes; add the missing ones"):
        w.commit()
    assert not list(tmp_path.glob("*.h5*"))


_KILLED_CALLER = """
import sys, time
from collections.abc import Callable
from pathlib import Path
from typing import Any
from nsrmp_bench.storage import open as open_part
from nsrmp_bench.storage.writer import shard_writer
with open_part(Path(sys.argv[1])) as part:
    first = part.episode(0)
w = shard_writer(sys.argv[2], 0, 2, split="smoke-v2/test", background="process")
w.add(first)
print(w._child._proc.pid, flush=True)
time.sleep(60)
"""


def test_the_writer_process_removes_its_file_when_its_caller_is_killed(
    smoke_v2_test: Path, tmp_path: Path
) -> None:
    caller = subprocess.Popen([sys.executable, "-c", _KILLED_CALLER, str(smoke_v2_test),
                               str(tmp_path)], stdout=subprocess.PIPE, text=True)
    assert caller.stdout is not None
    child = int(caller.stdout.readline())
    assert list(tmp_path.glob("*.h5.tmp"))  # the shard is being written
    caller.send_signal(signal.SIGKILL)
    caller.wait()
    deadline = time.monotonic() + 20.0
    while _alive(child):
        if time.monotonic() > deadline:
            pytest.fail(f"the writer process {child} outlived its killed caller")
        time.sleep(0.05)
    assert not list(tmp_path.glob("*.h5*"))


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (an exited orphan nobody reaped yet, a zombie, does not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


def _mode(out: mp.SimpleQueue[str]) -> None:
    out.put(writer_mode())


def test_a_daemonic_process_writes_on_a_thread() -> None:
    ctx = mp.get_context("fork")
    out: mp.SimpleQueue[str] = ctx.SimpleQueue()
    for daemon, expected in ((True, "thread"), (False, "process")):
        proc = ctx.Process(target=_mode, args=(out,), daemon=daemon)
        proc.start()
        proc.join()
        assert out.get() == expected
