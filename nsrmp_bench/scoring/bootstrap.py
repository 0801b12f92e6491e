"""Percentile bootstrap intervals and a paired sign-flip test, vectorised over instances.

Every figure the scorer reports is a mean of per-instance values over the instances where
the metric is defined (NaN marks "not defined here", e.g. identification accuracy on a
two-step instance). One bootstrap resample gives instance i a count w_i (how often it is
drawn); the resampled figure is sum(w v) / sum(w) over the defined instances. All
metrics, and every group of a breakdown, use the same resamples, and a chunk of resamples
costs one matrix product with the value matrix (weights are laid out instance-major,
``(n, resamples)``, so each group of a breakdown is a contiguous block of rows).

Resampling is the classical one (multinomial counts: n draws with replacement) up to
:data:`POISSON_ABOVE` instances, and the Poisson bootstrap (independent Poisson(1)
counts, its standard large-sample equivalent, several times cheaper to draw) above that.

Randomness comes only from the ``numpy.random.Generator`` passed in.

**The same bits on every CPU.** BLAS picks its matrix-product kernels by CPU (AVX2,
AVX-512, ...), and in floating point their different summation orders and fused
multiply-adds give different last bits. So the values enter the products on a grid of
:data:`GRID` (2^-24, float32's resolution on [0.5, 1)), in float64: every product of a
count and a grid value and every partial sum is then an exact float64 (exact while a sum
stays below 2^29), so any kernel, in any order, returns the same sums, and the ratios,
quantiles and p-values computed from them are the same bits everywhere.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidArgument

__all__ = [
    "GRID",
    "POISSON_ABOVE",
    "GroupIntervals",
    "Intervals",
    "bootstrap_intervals",
    "multinomial_weights",
    "poisson_weights",
    "resampling_method",
    "sign_flip_pvalues",
]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

_CHUNK_ELEMENTS = 4_000_000  # weights per chunk (instances x resamples)

GRID = 2.0**-24
"""Values are rounded to multiples of this before the (exact) bootstrap products."""

POISSON_ABOVE = 10_000
"""Instances above which resampling switches from multinomial to Poisson counts."""


def _on_grid(a: NDArray[np.floating]) -> F64:
    """``a`` rounded to multiples of :data:`GRID` (float64; exact operations only)."""
    out: F64 = np.rint(np.asarray(a, dtype=np.float64) / GRID) * GRID
    return out


def _check(n_boot: int, level: float) -> None:
    if not isinstance(n_boot, int) or n_boot < 0:
        msg = f"n_boot must be a non-negative integer (0 = no intervals), got {n_boot!r}"
        raise InvalidArgument(msg)
    if not 0.0 < level < 1.0:
        msg = f"the confidence level must lie strictly between 0 and 1 (e.g. 0.95), got {level!r}"
        raise InvalidArgument(msg)


def multinomial_weights(rng: np.random.Generator, n: int, size: int) -> NDArray[np.uint16]:
    """``size`` classical bootstrap resamples of ``n`` instances, as counts ``(n, size)``.

    Column b holds how often each instance is drawn in n draws with replacement.
    """
    out = np.empty((n, size), dtype=np.uint16)
    top = np.iinfo(np.uint16).max
    for j in range(size):
        counts = np.bincount(rng.integers(0, n, size=n, dtype=np.int64), minlength=n)
        out[:, j] = np.minimum(counts, top)
    return out


def _poisson_table() -> NDArray[np.uint8]:
    """Poisson(1) quantiles of the 65536 equally likely 16-bit values."""
    pmf = [math.exp(-1.0) / math.factorial(k) for k in range(20)]
    cdf = np.cumsum(pmf)
    u = (np.arange(65536, dtype=np.float64) + 0.5) / 65536.0
    table: NDArray[np.uint8] = np.searchsorted(cdf, u, side="right").astype(np.uint8)
    return table


_POISSON = _poisson_table()


def poisson_weights(rng: np.random.Generator, n: int, size: int) -> NDArray[np.uint8]:
    """``size`` Poisson bootstrap resamples: independent Poisson(1) counts ``(n, size)``.

    Probabilities are resolved to 1/65536 (16 random bits per count).
    """
    u = np.frombuffer(rng.bytes(2 * size * n), dtype=np.uint16)
    return _POISSON[u].reshape(n, size)


def resampling_method(n: int) -> str:
    """How :func:`bootstrap_intervals` resamples ``n`` instances."""
    return "poisson" if n > POISSON_ABOVE else "multinomial"


def _chunks(n: int, n_boot: int) -> Iterator[tuple[int, int]]:
    step = max(1, min(n_boot, _CHUNK_ELEMENTS // max(n, 1)))
    for start in range(0, n_boot, step):
        yield start, min(n_boot, start + step)


def _ratio(sums: NDArray[np.floating], k: int, mask_of: I64) -> F64:
    """Resampled means ``(resamples, K)`` from sums ``(K + masks, resamples)``."""
    s = sums.astype(np.float64)
    num = s[:k].T
    den = s[k:][mask_of].T
    with np.errstate(invalid="ignore", divide="ignore"):
        out: F64 = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
    return out


def _quantile(ordered: F64, valid: I64, q: float) -> F64:
    """Linear-interpolation quantile (numpy's default) of each column's first ``valid``."""
    pos = q * np.maximum(valid - 1, 0).astype(np.float64)
    lo = np.floor(pos).astype(np.int64)
    hi = np.minimum(lo + 1, np.maximum(valid - 1, 0))
    a = np.take_along_axis(ordered, lo[None], axis=0)[0]
    b = np.take_along_axis(ordered, hi[None], axis=0)[0]
    out: F64 = np.where(valid > 0, a + (b - a) * (pos - lo), np.nan)
    return out


def _quantiles(samples: F64, level: float) -> tuple[F64, F64]:
    """Percentile interval ends over axis 0, ignoring NaN (resamples where undefined)."""
    ordered = np.sort(samples, axis=0)  # NaN sorts last
    valid = (~np.isnan(samples)).sum(axis=0)
    return (_quantile(ordered, valid, (1.0 - level) / 2.0),
            _quantile(ordered, valid, (1.0 + level) / 2.0))


@dataclass(frozen=True)
class Intervals:
    """Point estimates and interval ends ``(K,)`` of K metrics, and their instance counts."""

    mean: F64
    low: F64
    high: F64
    n: I64


@dataclass(frozen=True)
class GroupIntervals:
    """Per group of one categorisation: estimates and interval ends ``(G, K)``, counts."""

    mean: F64
    low: F64
    high: F64
    n: I64


def _means(values: F64, mask: NDArray[np.bool_]) -> tuple[F64, I64]:
    n = mask.sum(axis=0).astype(np.int64)
    total = np.where(mask, values, 0.0).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(n > 0, total / np.maximum(n, 1), np.nan)
    return mean, n


@dataclass(frozen=True)
class _Grouping:
    perm: I64  # instances sorted by group
    bounds: I64  # (G+1,) group g is perm[bounds[g]:bounds[g+1]]
    x: F64  # the value matrix in that order, on the grid
    n_groups: int


def bootstrap_intervals(
    values: NDArray[np.floating],
    rng: np.random.Generator,
    *,
    n_boot: int = 1000,
    level: float = 0.95,
    groupings: Sequence[tuple[I64, int]] = (),
    group_intervals: bool = True,
) -> tuple[Intervals, list[GroupIntervals]]:
    """Means and percentile bootstrap intervals of each column of ``values`` ``(n, K)``.

    NaN entries are "not defined for this instance" and take no part. ``groupings`` are
    ``(codes, n_groups)`` pairs: codes ``(n,)`` in ``0..n_groups-1`` assign each instance to
    a group, and each group's means (and, with ``group_intervals``, intervals from the
    same resamples) are returned too. ``n_boot=0`` gives NaN interval ends. A column
    defined on no instance (e.g. abstention on data where no gold abstains) takes no part
    in the resampling: its mean and interval ends are NaN, its counts 0.
    """
    _check(n_boot, level)
    v = np.asarray(values, dtype=np.float64)
    if v.ndim != 2:
        msg = f"values must be a 2-D array (instances, metrics), got shape {v.shape}"
        raise InvalidArgument(msg)
    defined: NDArray[np.bool_] = np.asarray(~np.isnan(v).all(axis=0), dtype=bool)
    if len(v) and not defined.all():
        return _expand(bootstrap_intervals(v[:, defined], rng, n_boot=n_boot, level=level,
                                           groupings=groupings,
                                           group_intervals=group_intervals), defined)
    n, k = v.shape
    mask = ~np.isnan(v)
    # One weight column per distinct mask (most metrics are defined on every instance).
    packed = np.packbits(mask, axis=0)
    distinct: dict[bytes, int] = {}
    mask_of = np.array(
        [distinct.setdefault(packed[:, j].tobytes(), len(distinct)) for j in range(k)],
        dtype=np.int64,
    )
    first = [int(np.flatnonzero(mask_of == d)[0]) for d in range(len(distinct))]
    x = np.concatenate([np.where(mask, v, 0.0), mask[:, first].astype(np.float64)], axis=1)
    mean, count = _means(v, mask)

    prepared: list[_Grouping] = []
    group_out: list[GroupIntervals] = []
    for codes, n_groups in groupings:
        c = np.asarray(codes, dtype=np.int64)
        if c.shape != (n,) or (n and (c.min() < 0 or c.max() >= n_groups)):
            msg = f"group codes must have shape ({n},) with values in 0..{n_groups - 1}"
            raise InvalidArgument(msg)
        perm = np.argsort(c, kind="stable")
        bounds = np.searchsorted(c[perm], np.arange(n_groups + 1))
        gmean = np.full((n_groups, k), np.nan)
        gn = np.zeros((n_groups, k), dtype=np.int64)
        for g in range(n_groups):
            sel = perm[bounds[g] : bounds[g + 1]]
            gmean[g], gn[g] = _means(v[sel], mask[sel])
        if group_intervals:
            prepared.append(_Grouping(perm, bounds, _on_grid(x[perm]), n_groups))
        group_out.append(GroupIntervals(gmean, gmean * np.nan, gmean * np.nan, gn))
    if n_boot == 0 or n == 0:
        nan = np.full(k, np.nan)
        return Intervals(mean, nan, nan.copy(), count), group_out

    weights = poisson_weights if resampling_method(n) == "poisson" else multinomial_weights
    samples = np.empty((n_boot, k))
    gsamples = [np.empty((n_boot, gr.n_groups, k)) for gr in prepared]
    xt = np.ascontiguousarray(_on_grid(x).T)  # (K + masks, n): exact products, any kernel
    step = next(_chunks(n, n_boot))[1]
    wf = np.empty((n, step), dtype=np.float64)  # reused: no fresh pages per chunk
    gbuf = np.empty((n, step), dtype=np.float64)
    ubuf = np.empty((0, 0), dtype=np.uint16)
    for start, stop in _chunks(n, n_boot):
        size = stop - start
        w = weights(rng, n, size)
        wf_c = wf[:, :size]
        np.copyto(wf_c, w)
        samples[start:stop] = _ratio(xt @ wf_c, k, mask_of)
        if prepared and (ubuf.shape != w.shape or ubuf.dtype != w.dtype):
            ubuf = np.empty(w.shape, dtype=w.dtype)
        for gr, out in zip(prepared, gsamples, strict=True):
            gw = gbuf[:, :size]
            np.take(w, gr.perm, axis=0, out=ubuf)  # gather the small integer counts
            np.copyto(gw, ubuf)
            for g in range(gr.n_groups):
                s, e = int(gr.bounds[g]), int(gr.bounds[g + 1])
                out[start:stop, g] = _ratio(gr.x[s:e].T @ gw[s:e], k, mask_of)
    low, high = _quantiles(samples, level)
    if prepared:
        final_groups = []
        for gi, gs in zip(group_out, gsamples, strict=True):
            glow, ghigh = _quantiles(gs, level)
            final_groups.append(GroupIntervals(gi.mean, glow, ghigh, gi.n))
        group_out = final_groups
    return Intervals(mean, low, high, count), group_out


def _expand(out: tuple[Intervals, list[GroupIntervals]], defined: NDArray[np.bool_],
            ) -> tuple[Intervals, list[GroupIntervals]]:
    """Results for the ``defined`` columns laid out over every column (NaN, count 0)."""
    def wide(a: F64) -> F64:
        full: F64 = np.full((*a.shape[:-1], len(defined)), np.nan)
        full[..., defined] = a
        return full

    def count(a: I64) -> I64:
        full: I64 = np.zeros((*a.shape[:-1], len(defined)), dtype=np.int64)
        full[..., defined] = a
        return full

    iv, groups = out
    return (Intervals(wide(iv.mean), wide(iv.low), wide(iv.high), count(iv.n)),
            [GroupIntervals(wide(g.mean), wide(g.low), wide(g.high), count(g.n))
             for g in groups])


def sign_flip_pvalues(
    differences: NDArray[np.floating],
    rng: np.random.Generator,
    *,
    n_perm: int = 10000,
) -> F64:
    """Two-sided p-values ``(K,)`` of a paired sign-flip permutation test per column.

    Under the null hypothesis that two systems score alike, each instance's difference is
    as likely to be negative as positive; the p-value is the share of random sign flips
    whose mean difference is at least as far from zero as the observed one, counting the
    observed assignment (so it is never 0). NaN entries take no part; a column with no
    defined entries gets NaN.
    """
    if not isinstance(n_perm, int) or n_perm < 1:
        msg = f"n_perm must be a positive integer, got {n_perm!r}"
        raise InvalidArgument(msg)
    d = np.asarray(differences, dtype=np.float64)
    n, k = d.shape
    mask = ~np.isnan(d)
    dz = _on_grid(np.where(mask, d, 0.0))  # on the grid: every sum below is exact
    count = mask.sum(axis=0)
    observed = np.abs(dz.sum(axis=0))
    # Near-ties count as hits (the margin is far below any real difference).
    tol = 1e-6 * np.abs(dz).sum(axis=0) + 1e-12
    hits = np.zeros(k, dtype=np.int64)
    dt = np.ascontiguousarray(dz.T)  # (K, n)
    for start, stop in _chunks(n, n_perm):
        size = stop - start
        bits = np.unpackbits(
            np.frombuffer(rng.bytes((size * n + 7) // 8), dtype=np.uint8), count=size * n
        )
        signs = bits.reshape(n, size).astype(np.float64) * 2.0 - 1.0
        sums = np.abs(dt @ signs)  # (K, size), exact
        hits += (sums >= (observed - tol)[:, None]).sum(axis=1)
    p = (1.0 + hits.astype(np.float64)) / (1.0 + n_perm)
    out: F64 = np.where(count > 0, p, np.nan)
    return out
