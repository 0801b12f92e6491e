"""DEFLATE resumed from a checkpoint of a stream that begins with the same bytes.

A shard's images share their camera's empty scene: a composite render is the cached
background with the objects drawn over it, so the rows above the highest object are the
same bytes in every image of a split (about half of an RGB image at 320x240). Stock zlib's
output at levels 1-9 does not depend on how its input is split between ``compress`` calls
(without flushes), and a compressor's whole state can be copied (``zlib.Compress.copy``).
So :class:`PrefixDeflater` compresses a *reference* stream once, keeping a copy of the
compressor every ``step`` bytes with the output so far; a stream whose first ``d`` bytes
equal the reference's takes the last checkpoint at or before ``d`` and compresses only the
rest. The result is exactly ``zlib.compress(raw, level)``, whatever the reference: a poor
one only saves less (tests compare every stream with ``zlib.compress``). Level 0 (stored
blocks, sized by how the input arrives) is always compressed whole, and a zlib build whose
output does depend on the split (checked once per reference, resuming from its middle
checkpoint) is never resumed.

The reference is learnt from the streams themselves, so nothing outside storage has to
know about backgrounds: a kind of stream (the caller's ``kind``, with the level and the
stream's length) keeps the first stream it is given in each of its first ``votes``
episodes, and its reference is their byte-wise majority (with three different scenes, the
background wherever no two of them have an object on the same byte).
"""

from __future__ import annotations

import zlib
from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidArgument

__all__ = ["PrefixDeflater"]


@dataclass
class _Reference:
    """A reference stream compressed once: the compressor's state every ``step`` bytes."""

    stream: NDArray[np.uint8]
    step: int
    output: bytes
    """The reference's whole output before its flush."""
    states: list[tuple[zlib._Compress, int]]
    """(the compressor after ``j * step`` bytes, the length of its output so far); empty
    where this zlib's output depends on how the input is split (never resumed)."""

    def resumed(self, raw: bytes, j: int) -> bytes:
        """``raw``, whose first ``j * step`` bytes are the reference's, compressed from the
        ``j``-th checkpoint."""
        state, produced = self.states[j]
        compressor = state.copy()
        return b"".join((memoryview(self.output)[:produced],
                         compressor.compress(memoryview(raw)[j * self.step:]),
                         compressor.flush()))


def _first_difference(a: NDArray[np.uint8], b: NDArray[np.uint8]) -> int:
    """Index of the first byte where ``a`` and ``b`` (of one length) differ; their length
    if none does. Compared eight bytes at a time where the length allows."""
    if len(a) % 8 == 0:
        words = np.flatnonzero(a.view(np.uint64) != b.view(np.uint64))
        if not len(words):
            return len(a)
        start = int(words[0]) * 8
        return start + int(np.flatnonzero(a[start:start + 8] != b[start:start + 8])[0])
    diff = np.flatnonzero(a != b)
    return int(diff[0]) if len(diff) else len(a)


class PrefixDeflater:
    """``zlib.compress`` that skips the leading bytes a stream shares with a learnt
    reference of its kind (module doc).

    ``votes`` episodes make a kind's reference; at most ``checkpoints`` compressor states
    (about 256 KiB each at the default memory level) are kept per kind, ``min_step`` bytes
    apart at least. Not thread-safe: one per writer."""

    def __init__(self, *, votes: int = 3, checkpoints: int = 32, min_step: int = 8192) -> None:
        if votes < 1 or votes % 2 == 0 or votes > 255:
            msg = (f"votes must be an odd number from 1 to 255 (a byte-wise majority), got "
                   f"{votes}")
            raise InvalidArgument(msg)
        if checkpoints < 1 or min_step < 1:
            msg = (f"checkpoints and min_step must be >= 1, got {checkpoints} and "
                   f"{min_step}")
            raise InvalidArgument(msg)
        self._votes = votes
        self._max_checkpoints = checkpoints
        self._min_step = min_step
        self._candidates: dict[Hashable, list[NDArray[np.uint8]]] = {}
        self._references: dict[Hashable, _Reference] = {}
        self._voted: set[Hashable] = set()  # kinds that gave a candidate this episode
        self.resumed_bytes = 0
        """Input bytes not compressed again because a checkpoint covered them."""

    def next_episode(self) -> None:
        """Streams from now on belong to another episode (a kind takes one candidate for
        its reference per episode, so that the vote is between different scenes)."""
        self._voted.clear()

    def compress(self, raw: bytes, level: int, kind: Hashable) -> bytes:
        """``zlib.compress(raw, level)``, resumed from the reference of ``kind`` (with
        ``level`` and ``len(raw)``) where one covers its first bytes."""
        if level == 0:  # stored blocks: their sizes follow how the input arrives
            return zlib.compress(raw, level)
        key = (kind, level, len(raw))
        data = np.frombuffer(raw, np.uint8)
        ref = self._references.get(key)
        if ref is None:
            self._vote(key, data, level)
            return zlib.compress(raw, level)
        j = min(_first_difference(data, ref.stream) // ref.step, len(ref.states) - 1)
        if j <= 0:  # nothing shared before the first checkpoint (or none kept)
            return zlib.compress(raw, level)
        self.resumed_bytes += j * ref.step
        return ref.resumed(raw, j)

    def _vote(self, key: Hashable, data: NDArray[np.uint8], level: int) -> None:
        """Keep ``data`` as a candidate for its kind's reference (the first stream of the
        kind in this episode); with ``votes`` of them, make the reference."""
        if key in self._voted:
            return
        self._voted.add(key)
        candidates = self._candidates.setdefault(key, [])
        candidates.append(data)  # a view of the caller's bytes, which cannot change
        if len(candidates) < self._votes:
            return
        del self._candidates[key]
        step = max(self._min_step, -(-len(data) // self._max_checkpoints))
        self._references[key] = _build_reference(_majority(candidates), level, step)


def _majority(candidates: list[NDArray[np.uint8]]) -> NDArray[np.uint8]:
    """The byte-wise majority of an odd number (at most 255) of streams, one pass each
    (Boyer-Moore's vote); where no byte value holds a majority, one of the values."""
    winner = candidates[0].copy()
    count = np.ones(len(winner), np.uint8)
    for stream in candidates[1:]:
        same = stream == winner
        fresh = count == 0
        winner[fresh] = stream[fresh]
        count += (same | fresh).astype(np.uint8)
        count -= (~same & ~fresh).astype(np.uint8)
    return winner


def _build_reference(stream: NDArray[np.uint8], level: int, step: int) -> _Reference:
    """``stream`` compressed once, its compressor copied every ``step`` bytes; no states
    if resuming from the middle checkpoint does not give this zlib's own output."""
    raw = stream.tobytes()
    compressor = zlib.compressobj(level)
    pieces: list[bytes] = []
    produced = 0
    states: list[tuple[zlib._Compress, int]] = []
    for offset in range(0, len(raw), step):
        states.append((compressor.copy(), produced))
        piece = compressor.compress(raw[offset:offset + step])
        pieces.append(piece)
        produced += len(piece)
    reference = _Reference(stream, step, b"".join(pieces), states)
    if len(states) > 1 and reference.resumed(raw, len(states) // 2) != zlib.compress(raw, level):
        reference.states = []
    return reference
