"""Bootstrap intervals and the paired sign-flip test."""

from __future__ import annotations

import numpy as np
import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scoring.bootstrap import (
    POISSON_ABOVE,
    bootstrap_intervals,
    multinomial_weights,
    poisson_weights,
    resampling_method,
    sign_flip_pvalues,
)


def test_weights_are_resamples_of_n() -> None:
    w = multinomial_weights(np.random.default_rng(0), 50, 20)
    assert w.shape == (50, 20)
    assert (w.sum(axis=0) == 50).all()
    assert w.dtype == np.uint16


def test_poisson_weights_have_poisson_one_counts() -> None:
    w = poisson_weights(np.random.default_rng(0), 100_000, 4).astype(float)
    assert w.mean() == pytest.approx(1.0, abs=0.01)
    assert w.var() == pytest.approx(1.0, abs=0.02)
    assert (w == 0).mean() == pytest.approx(np.exp(-1), abs=0.01)


def test_large_sets_use_poisson_resampling() -> None:
    n = POISSON_ABOVE + 1
    assert resampling_method(n) == "poisson" and resampling_method(500) == "multinomial"
    rng = np.random.default_rng(4)
    values = (rng.random((n, 1)) < 0.5).astype(float)
    out, _ = bootstrap_intervals(values, rng, n_boot=300)
    se = values.std(ddof=1) / np.sqrt(n)
    assert out.high[0] - out.low[0] == pytest.approx(2 * 1.96 * se, rel=0.2)


def test_intervals_are_seeded_and_bracket_the_mean() -> None:
    rng = np.random.default_rng(1)
    values = np.stack([rng.random(300), rng.random(300) < 0.3], axis=1).astype(float)
    a, _ = bootstrap_intervals(values, np.random.default_rng(5), n_boot=400)
    b, _ = bootstrap_intervals(values, np.random.default_rng(5), n_boot=400)
    c, _ = bootstrap_intervals(values, np.random.default_rng(6), n_boot=400)
    assert np.array_equal(a.low, b.low) and np.array_equal(a.high, b.high)
    assert not np.array_equal(a.low, c.low)
    assert np.allclose(a.mean, values.mean(axis=0))
    assert (a.low < a.mean).all() and (a.mean < a.high).all()
    # The percentile interval of a mean is close to the normal one at this size.
    se = values.std(axis=0, ddof=1) / np.sqrt(300)
    assert np.allclose(a.high - a.low, 2 * 1.96 * se, rtol=0.2)


def test_constant_and_undefined_columns() -> None:
    values = np.array([[1.0, np.nan], [1.0, np.nan], [1.0, 0.5]])
    out, _ = bootstrap_intervals(values, np.random.default_rng(0), n_boot=200)
    assert out.low[0] == out.high[0] == 1.0
    assert out.n.tolist() == [3, 1]
    assert out.mean[1] == 0.5


def test_groups_use_their_own_instances() -> None:
    rng = np.random.default_rng(2)
    codes = rng.integers(0, 3, 500)
    values = (codes[:, None] + rng.random((500, 1)) * 0.1).astype(float)
    _, (groups,) = bootstrap_intervals(values, rng, n_boot=300, groupings=[(codes, 4)])
    for g in range(3):
        sel = codes == g
        assert groups.mean[g, 0] == pytest.approx(values[sel, 0].mean())
        assert groups.n[g, 0] == sel.sum()
        assert groups.low[g, 0] <= groups.mean[g, 0] <= groups.high[g, 0]
        assert g <= groups.low[g, 0] and groups.high[g, 0] <= g + 0.1
    assert groups.n[3, 0] == 0 and np.isnan(groups.mean[3, 0])  # an empty group


def test_no_resamples_gives_no_interval() -> None:
    out, _ = bootstrap_intervals(np.ones((4, 1)), np.random.default_rng(0), n_boot=0)
    assert np.isnan(out.low).all() and out.mean[0] == 1.0


@pytest.mark.parametrize("kw", [{"n_boot": -1}, {"level": 1.0}, {"level": 0.0}])
def test_bad_settings(kw: dict[str, float]) -> None:
    with pytest.raises(InvalidArgument):
        bootstrap_intervals(np.ones((3, 1)), np.random.default_rng(0), **kw)  # type: ignore[arg-type]


def test_sign_flip_test() -> None:
    rng = np.random.default_rng(3)
    same = np.zeros((50, 1))
    assert sign_flip_pvalues(same, rng, n_perm=500)[0] == 1.0
    better = np.full((50, 1), 0.2)  # every instance better: only the all-plus flip reaches it
    assert sign_flip_pvalues(better, rng, n_perm=999)[0] == pytest.approx(1 / 1000)
    noise = rng.normal(0, 1, (200, 1))
    noise -= noise.mean()
    assert sign_flip_pvalues(noise, rng, n_perm=999)[0] > 0.5
    assert np.isnan(sign_flip_pvalues(np.full((5, 1), np.nan), rng, n_perm=10)[0])
