"""Shared-memory handover to a forked child: what the child unpacks is what was packed,
its large arrays are views of the slot (not copies), slots are reused only once freed,
what does not fit goes by the pipe, and a parent waiting for a dead child does not hang."""

from __future__ import annotations

import hashlib
import multiprocessing as mp
import time
from multiprocessing.connection import Connection
from typing import Any

import numpy as np
import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.handover import Handover

if "fork" not in mp.get_all_start_methods():
    pytest.skip("the handover is for forked writer processes", allow_module_level=True)
CTX = mp.get_context("fork")


def _objects(k: int) -> list[dict[str, Any]]:
    rng = np.random.default_rng(k)
    return [{"k": k, "image": rng.integers(0, 255, (240, 320, 3), dtype=np.uint8),
             "depth": rng.random((2, 240, 320), dtype=np.float32),
             "small": np.arange(10, dtype=np.float64), "text": f"episode {k}"}]


def _digest(obj: dict[str, Any]) -> str:
    h = hashlib.sha256(obj["text"].encode())
    for key in ("image", "depth", "small"):
        h.update(np.ascontiguousarray(obj[key]).tobytes())
    return h.hexdigest()


def _memory(arr: np.ndarray[Any, Any]) -> str:
    """What an unpickled array's memory belongs to (``mmap``: the shared mapping)."""
    base = arr.base
    while isinstance(base, np.ndarray):
        base = base.base
    return type(base.obj).__name__ if isinstance(base, memoryview) else "own"


def _child(handover: Handover, inbox: Connection, outbox: Connection) -> None:
    while True:
        packed = inbox.recv()
        if packed is None:
            return
        obj = handover.unpack(packed)
        outbox.send((_digest(obj), _memory(obj["image"]), _memory(obj["small"])))
        del obj
        handover.release()


def _recv(conn: Connection) -> Any:
    assert conn.poll(20), "the child did not answer"
    return conn.recv()


def test_the_child_unpacks_what_was_packed_as_views_of_the_slots() -> None:
    handover = Handover(CTX, slots=2, slot_bytes=4 * 1024 * 1024)
    inbox_r, inbox_w = CTX.Pipe(duplex=False)
    outbox_r, outbox_w = CTX.Pipe(duplex=False)
    child = CTX.Process(target=_child, args=(handover, inbox_r, outbox_w), daemon=True)
    child.start()
    inbox_r.close()
    outbox_w.close()
    try:
        sent = [obj for k in range(7) for obj in _objects(k)]  # more objects than slots
        got: list[tuple[str, str, str]] = []
        for i, obj in enumerate(sent):
            packed = handover.pack(obj, lambda: None)
            assert packed is not None
            slot, meta, spans = packed
            assert slot == i % 2  # in turn
            assert len(spans) == 2  # image and depth out of band; the small array in band
            assert len(meta) < 10_000
            inbox_w.send(packed)
            if i % 3 == 2:  # now and then wait for the child, so both orders happen
                got.extend(_recv(outbox_r) for _ in range(i + 1 - len(got)))
        got.extend(_recv(outbox_r) for _ in range(len(sent) - len(got)))
        inbox_w.send(None)
        child.join(10)
        assert child.exitcode == 0
    finally:
        if child.is_alive():
            child.terminate()
        handover.close()
    assert [g[0] for g in got] == [_digest(o) for o in sent]
    # the large arrays are views of the shared mapping; the small one came in the pickle
    assert {image for _, image, _ in got} == {"mmap"}
    assert "mmap" not in {small for _, _, small in got}


def test_what_is_too_large_for_a_slot_or_has_no_large_buffer_is_not_packed() -> None:
    handover = Handover(CTX, slots=1, slot_bytes=64 * 1024)
    try:
        assert handover.pack(_objects(0)[0], lambda: None) is None
        assert handover.pack({"small": np.zeros(10)}, lambda: None) is None
        # neither took the only slot: an object that fits still gets it, at once
        fits = {"a": np.zeros(64 * 1024, dtype=np.uint8)}  # out of band, fills the slot
        packed = handover.pack(fits, lambda: pytest.fail("waited for a free slot"))
        assert packed is not None and packed[0] == 0
    finally:
        handover.close()


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"slots": 0}, "at least one slot of a positive multiple of 64 bytes, got 0 slots"),
    ({"slot_bytes": 1000}, "got 2 slots of 1000 bytes"),
])
def test_bad_slots_are_refused(kwargs: dict[str, int], match: str) -> None:
    with pytest.raises(InvalidArgument, match=match):
        Handover(CTX, **kwargs)


def test_a_context_that_does_not_fork_is_refused() -> None:
    with pytest.raises(InvalidArgument, match=r"needs a fork context .* got 'spawn'"):
        Handover(mp.get_context("spawn"))


def _taker(handover: Handover, inbox: Connection) -> None:
    handover.unpack(inbox.recv())  # and exits without releasing the slot


def test_a_parent_waiting_for_a_slot_of_a_dead_child_is_told() -> None:
    handover = Handover(CTX, slots=1, slot_bytes=4 * 1024 * 1024)
    inbox_r, inbox_w = CTX.Pipe(duplex=False)
    child = CTX.Process(target=_taker, args=(handover, inbox_r), daemon=True)
    child.start()
    inbox_r.close()
    first = handover.pack(_objects(0)[0], lambda: None)
    inbox_w.send(first)
    child.join(10)
    checks = 0

    def alive() -> None:
        nonlocal checks
        checks += 1
        if not child.is_alive():
            raise RuntimeError("the child is gone")

    start = time.monotonic()
    with pytest.raises(RuntimeError, match="the child is gone"):
        handover.pack(_objects(1)[0], alive)  # the only slot is never freed
    assert checks >= 1 and time.monotonic() - start < 5.0
    handover.close()


def test_free_says_whether_pack_would_wait_and_takes_no_slot() -> None:
    handover = Handover(CTX, slots=2, slot_bytes=4 * 1024 * 1024)
    assert handover.free() and handover.free()  # asking twice takes nothing
    assert handover.pack(_objects(0)[0], lambda: None) is not None
    assert handover.free()  # one slot left
    assert handover.pack(_objects(1)[0], lambda: None) is not None
    assert not handover.free()  # both hold objects the child has not released
    handover.release()
    assert handover.free()
    handover.close()


def test_idle_says_whether_the_child_has_released_every_slot_and_takes_none() -> None:
    handover = Handover(CTX, slots=2, slot_bytes=4 * 1024 * 1024)
    assert handover.idle() and handover.idle()  # asking twice takes nothing
    assert handover.pack(_objects(0)[0], lambda: None) is not None
    assert handover.free() and not handover.idle()  # a slot left, but one is held
    handover.release()
    assert handover.idle()
    assert handover.pack(_objects(1)[0], lambda: None) is not None  # the slots still turn
    assert handover.pack(_objects(2)[0], lambda: None) is not None
    assert not handover.free() and not handover.idle()
    handover.release()
    handover.release()
    assert handover.idle()
    handover.close()


def test_room_counts_buffers_as_pack_lays_them_out() -> None:
    handover = Handover(CTX, slots=1, slot_bytes=4096)
    assert handover.room([]) == 4096
    assert handover.room([1, 64, 65]) == 4096 - 64 - 64 - 128
    assert handover.room([4097]) < 0
    handover.close()
