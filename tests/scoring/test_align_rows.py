"""The bounds check and the row copy that lay a submission out like its gold: the same
answers as the plain per-coordinate forms, NaN included."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from nsrmp_bench.scoring.align import _bounds
from nsrmp_bench.scoring.ragged import copy_rows


def _plain_bounds(arr: Any, width: Any, height: Any, tol: float) -> tuple[Any, Any]:
    """Outside by more than ``tol`` / at all, coordinate by coordinate (NaN: inside)."""
    x, y = arr[:, 0::2], arr[:, 1::2]
    w, h = width[:, None], height[:, None]
    far = ((x < -tol) | (x > w + tol) | (y < -tol) | (y > h + tol)).any(axis=1)
    out = ((x < 0) | (x > w) | (y < 0) | (y > h)).any(axis=1)
    return far, out


@pytest.mark.parametrize("tol", [0.0, 1.0, 2.5])
def test_bounds_match_the_plain_form(tol: float) -> None:
    rng = np.random.default_rng(0)
    n = 20_000
    width = rng.choice([64.0, 320.0, 1024.0], n)
    height = rng.choice([48.0, 240.0, 768.0], n)
    arr = rng.uniform(-3.0, 1.0, (n, 4)) * 1.0
    arr[:, 0::2] += rng.uniform(0, 1, (n, 1)) * width[:, None]
    arr[:, 1::2] += rng.uniform(0, 1, (n, 1)) * height[:, None]
    edges = rng.random((n, 4)) < 0.05  # exactly on an edge, or just past it
    arr[edges] = rng.choice([0.0, -0.0, -tol, -tol - 1e-9, 1e300], int(edges.sum()))
    arr[rng.random((n, 4)) < 0.02] = np.nan
    far, out = _bounds(arr, width, height, tol)
    want_far, want_out = _plain_bounds(arr, width, height, tol)
    assert far.tolist() == want_far.tolist()
    assert out.tolist() == want_out.tolist()


def test_copy_rows_is_a_fancy_assignment() -> None:
    rng = np.random.default_rng(1)
    src = rng.normal(size=(50, 4))
    src[3] = [np.nan, -0.0, np.inf, 1.0]
    dst_idx = rng.permutation(80)[:30]
    src_idx = rng.integers(0, 50, 30)
    got = np.full((80, 4), np.nan)
    want = got.copy()
    copy_rows(got, dst_idx, src, src_idx)
    want[dst_idx] = src[src_idx]
    assert got.tobytes() == want.tobytes()


@pytest.mark.parametrize(
    ("dst", "src"),
    [
        (np.zeros((6, 4), np.float32), np.arange(12.0).reshape(3, 4)),  # casts
        (np.zeros((6, 4))[:, :3], np.arange(9.0).reshape(3, 3)),  # a strided view
        (np.zeros((6, 0)), np.zeros((3, 0))),  # rows of no values
        (np.zeros(6), np.arange(3.0)),  # 1-D
    ],
)
def test_copy_rows_falls_back_to_plain_assignment(dst: Any, src: Any) -> None:
    want = dst.copy()
    want[[5, 0, 2]] = src[[0, 2, 1]]
    copy_rows(dst, np.array([5, 0, 2]), src, np.array([0, 2, 1]))
    assert dst.tobytes() == want.tobytes()
