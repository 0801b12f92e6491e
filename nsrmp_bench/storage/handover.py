"""Handing objects to a forked writer process through shared memory, not the pipe.

An episode pickled whole is 1.4 MB at 320x240 and 14 MB at 1024x768, almost all of it
image arrays. Through a pipe, the parent copies them into the pickle and the kernel, and
the child copies them out again before unpickling (measured at 1024x768: 8 ms to pickle,
16 ms to unpickle an episode, a fifth of what writing it costs). Here the arrays travel
out of band (pickle protocol 5): the parent copies each large buffer once into a slot of
an anonymous shared mapping made before the fork, and sends only the small rest of the
pickle and where the buffers lie; the child unpickles arrays that are views of the slot,
without a copy, and frees the slot when it has written the object.

Slots are used in turn and counted by a semaphore, so the parent never overwrites a slot
the child still reads: with two slots, the child writes one episode while the parent
fills the next, and a parent two episodes ahead waits (:meth:`Handover.free` tells it
beforehand, so that it can do something useful first: the writer process compresses
image chunks for its child then). An object whose large buffers do
not fit a slot goes through the pipe as before (:meth:`Handover.pack` returns None).
"""

from __future__ import annotations

import mmap
import pickle
from collections.abc import Callable, Iterable
from multiprocessing.context import BaseContext
from typing import Any, TypeAlias

from nsrmp_bench.errors import InvalidArgument

__all__ = ["Handover", "Packed"]

Packed: TypeAlias = tuple[int, bytes, list[tuple[int, int]]]
"""(slot, the pickle without its large buffers, each buffer's (offset, size) in the slot)."""

_OUT_OF_BAND = 64 * 1024  # smaller buffers stay in the pickle
_ALIGN = 64


def _aligned(size: int) -> int:
    """The bytes a buffer of ``size`` takes in a slot (each starts at a multiple of 64)."""
    return -(-size // _ALIGN) * _ALIGN


class Handover:
    """Shared slots between a parent and the child it forks after making this.

    The parent calls :meth:`pack` and sends what it returns; the child calls
    :meth:`unpack`, and :meth:`release` once it no longer holds anything unpacked from
    that slot."""

    def __init__(self, ctx: BaseContext, *, slots: int = 2,
                 slot_bytes: int = 32 * 1024 * 1024) -> None:
        if ctx.get_start_method() != "fork":
            msg = (f"Handover needs a fork context (the child inherits the mapping), got "
                   f"{ctx.get_start_method()!r}; use multiprocessing.get_context('fork')")
            raise InvalidArgument(msg)
        if slots < 1 or slot_bytes < _ALIGN or slot_bytes % _ALIGN:
            msg = (f"Handover needs at least one slot of a positive multiple of {_ALIGN} "
                   f"bytes, got {slots} slots of {slot_bytes} bytes")
            raise InvalidArgument(msg)
        self.slots, self.slot_bytes = slots, slot_bytes
        # anonymous and MAP_SHARED: the forked child sees the parent's writes; pages are
        # only backed once touched
        self._map = mmap.mmap(-1, slots * slot_bytes)
        self._free = ctx.Semaphore(slots)
        self._next = 0

    def pack(self, obj: object, alive: Callable[[], None]) -> Packed | None:
        """Copy ``obj``'s large buffers into the next slot (waiting until the child has
        freed it; ``alive()`` is called while waiting and should raise if the child is
        gone); None when it has none (nothing to gain) or they do not fit a slot: send
        ``obj`` itself then."""
        raws: list[memoryview] = []  # the large buffers, laid out in the slot by spans
        spans: list[tuple[int, int]] = []
        end = 0

        def out_of_band(buf: pickle.PickleBuffer) -> bool:
            nonlocal end
            raw = buf.raw()
            if raw.nbytes < _OUT_OF_BAND:
                return True  # in band
            raws.append(raw)
            spans.append((end, raw.nbytes))
            end += _aligned(raw.nbytes)
            return False

        meta = pickle.dumps(obj, protocol=5, buffer_callback=out_of_band)
        if not raws or end > self.slot_bytes:
            return None
        while not self._free.acquire(timeout=0.2):
            alive()
        slot = self._next % self.slots
        try:
            base = slot * self.slot_bytes
            for raw, (off, size) in zip(raws, spans, strict=True):
                self._map[base + off:base + off + size] = raw
        except BaseException:  # nothing sent: the slot stays free and next in turn
            self._free.release()
            raise
        self._next += 1
        return slot, meta, spans

    def room(self, sizes: Iterable[int]) -> int:
        """Bytes a slot has left once it holds buffers of these sizes, laid out as
        :meth:`pack` lays them (negative: they do not fit)."""
        return self.slot_bytes - sum(_aligned(size) for size in sizes)

    def free(self) -> bool:
        """Whether a slot is free now, so that :meth:`pack` would not wait (the parent;
        only it takes slots, so a free one stays free until it packs)."""
        return self._free_slots(1)

    def idle(self) -> bool:
        """Whether every slot is free: the child has released all it was handed (the
        parent; the child only ever frees more)."""
        return self._free_slots(self.slots)

    def _free_slots(self, n: int) -> bool:
        """Whether ``n`` slots are free now; takes none (each taken to count is given back)."""
        taken = 0
        try:
            while taken < n and self._free.acquire(block=False):
                taken += 1
        finally:
            for _ in range(taken):
                self._free.release()
        return taken == n

    def unpack(self, packed: Packed) -> Any:
        """The object :meth:`pack` packed; its large arrays are views of the slot (read-only
        when the packed ones were), valid until :meth:`release`."""
        slot, meta, spans = packed
        base = slot * self.slot_bytes
        view = memoryview(self._map)
        return pickle.loads(meta, buffers=[view[base + off:base + off + size]
                                           for off, size in spans])

    def release(self) -> None:
        """Free the oldest slot in use (the child, once done with what it unpacked)."""
        self._free.release()

    def close(self) -> None:
        """Unmap the parent's slots, once the child has released every slot or stopped (its
        own mapping stays its own until it exits)."""
        self._map.close()
