"""Ragged arrays: variable-length rows stored flat with an offsets array.

Row ``i`` of a ragged array ``values`` with ``offsets`` is ``values[offsets[i]:offsets[i+1]]``;
``offsets`` has one more entry than there are rows and starts at 0. These helpers turn
per-row lengths into offsets, label every flat element with its row, gather rows, and
copy rows between arrays.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["copy_rows", "gather_rows", "offsets_from_lengths", "positions_in_rows", "row_ids"]

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


def copy_rows(dst: NDArray[Any], dst_idx: NDArray[Any], src: NDArray[Any],
              src_idx: NDArray[Any]) -> None:
    """``dst[dst_idx] = src[src_idx]`` along the first axis, in place.

    Rows of two C-contiguous 2-D arrays of one dtype and width move as single items (byte
    strings as wide as a row), which numpy copies faster than rows of separate values;
    anything else is assigned as written.
    """
    if (dst.ndim != 2 or dst.dtype != src.dtype or dst.shape[1:] != src.shape[1:]
            or not dst.shape[1] or not dst.flags.c_contiguous or not src.flags.c_contiguous):
        dst[dst_idx] = src[src_idx]
        return
    row = np.dtype((np.void, dst.dtype.itemsize * dst.shape[1]))
    dst.view(row).reshape(-1)[dst_idx] = src.view(row).reshape(-1)[src_idx]
