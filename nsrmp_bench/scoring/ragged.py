"""Ragged arrays: variable-length rows stored flat with an offsets array.

Row ``i`` of a ragged array ``values`` with ``offsets`` is ``values[offsets[i]:offsets[i+1]]``;
``offsets`` has one more entry than there are rows and starts at 0. These helpers turn
per-row lengths into offsets, label every flat element with its row, and gather rows.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["gather_rows", "offsets_from_lengths", "positions_in_rows", "row_ids"]

I64 = NDArray[np.int64]


def offsets_from_lengths(lengths: NDArray[Any]) -> I64:
    """Offsets ``(R+1,)`` of rows with the given lengths ``(R,)``."""
    out = np.zeros(len(lengths) + 1, dtype=np.int64)
    np.cumsum(np.asarray(lengths, dtype=np.int64), out=out[1:])
    return out


def row_ids(offsets: NDArray[Any]) -> I64:
    """The row of every flat element: ``(offsets[-1],)``."""
    off = np.asarray(offsets, dtype=np.int64)
    lengths = np.diff(off)
    return np.repeat(np.arange(len(lengths), dtype=np.int64), lengths)


def positions_in_rows(offsets: NDArray[Any]) -> I64:
    """The position of every flat element within its row: ``(offsets[-1],)``."""
    off = np.asarray(offsets, dtype=np.int64)
    total = int(off[-1])
    return np.arange(total, dtype=np.int64) - np.repeat(off[:-1], np.diff(off))


def gather_rows(offsets: NDArray[Any], rows: NDArray[Any]) -> tuple[I64, I64]:
    """Flat indices of the given rows, concatenated, and the offsets of the result.

    ``values[idx]`` with ``idx, new_offsets = gather_rows(offsets, rows)`` is the ragged
    array made of rows ``rows`` (in that order).
    """
    off = np.asarray(offsets, dtype=np.int64)
    r = np.asarray(rows, dtype=np.int64)
    starts = off[r]
    lengths = off[r + 1] - starts
    new_offsets = offsets_from_lengths(lengths)
    idx = np.repeat(starts - new_offsets[:-1], lengths) + np.arange(
        int(new_offsets[-1]), dtype=np.int64
    )
    return idx, new_offsets
