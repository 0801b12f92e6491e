"""The perception's size calibration: a prior fitted without labels, a scene read at the
scale that makes its sizes likely, and a scene of the training kind left as it is."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")

import torch

from nsrmp_bench.reference_model.program.size_calibration import (
    SizeCalibration,
    SizePrior,
    calibrated_sizes,
    fit_size_prior,
    scene_scale,
)

SMALL, BIG = (0.068, 0.079), (0.086, 0.093)


def _objects(rng: np.random.Generator, n: int, scale: float = 1.0) -> np.ndarray:
    big = rng.random(n) < 1 / 3
    means = np.where(big[:, None], BIG, SMALL)
    return (means + rng.normal(0, 0.004, (n, 2))) * scale


@pytest.fixture(scope="module")
def prior() -> SizePrior:
    return fit_size_prior(_objects(np.random.default_rng(0), 3000))


def test_the_prior_finds_the_two_sizes_without_labels(prior: SizePrior) -> None:
    order = np.argsort(prior.means[:, 0])
    np.testing.assert_allclose(prior.means[order], [SMALL, BIG], atol=0.002)
    assert prior.weights[order][0] == pytest.approx(2 / 3, abs=0.05)
    again = fit_size_prior(_objects(np.random.default_rng(0), 3000))
    assert again.values() == prior.values()  # deterministic
    assert SizePrior.from_values(prior.values()).values() == prior.values()


def test_a_shrunken_scene_is_read_at_the_training_scale(prior: SizePrior) -> None:
    rng = np.random.default_rng(1)
    settings = SizeCalibration()
    scales = [scene_scale(_objects(rng, 5, scale=0.88), prior, settings) for _ in range(40)]
    assert np.median(scales) == pytest.approx(1 / 0.88, abs=0.03)
    kept = [scene_scale(_objects(rng, 5), prior, settings) for _ in range(40)]
    assert np.mean(np.equal(kept, 1.0)) >= 0.9  # the training kind keeps its sizes
    assert scene_scale(np.zeros((0, 2)), prior, settings) == 1.0


def test_only_the_scene_s_objects_are_rescaled(prior: SizePrior) -> None:
    rng = np.random.default_rng(2)
    sizes = torch.zeros((2, 6, 2))
    sizes[0, :5] = torch.from_numpy(_objects(rng, 5, scale=0.85)).float()
    sizes[1, :4] = torch.from_numpy(_objects(rng, 4)).float()
    mask = sizes[..., 0] > 0
    before = sizes.clone()
    out = calibrated_sizes(sizes, mask, prior, SizeCalibration())
    assert float(out[0, 0, 0] / sizes[0, 0, 0]) > 1.1
    assert torch.equal(out[0, 5], sizes[0, 5])  # padding stays zero
    assert torch.equal(out[1], sizes[1])  # a scene of the training kind keeps its sizes
    assert torch.equal(sizes, before)  # the input is not changed in place


def test_a_bad_prior_names_the_fix() -> None:
    with pytest.raises(ValueError, match=r"5 values per component.*got 3.*fit_size_prior"):
        SizePrior.from_values((0.1, 0.2, 0.3))
    with pytest.raises(ValueError, match=r"at least 10 objects' sizes, got 2"):
        fit_size_prior(np.ones((2, 2)))


def test_the_shipped_v3_models_carry_their_calibration() -> None:
    from nsrmp_bench.reference_model.registry import load_model

    nsrm = load_model("nsrm-v3").config
    assert isinstance(nsrm, SizeCalibration)
    assert nsrm.size_calibration and len(nsrm.size_prior) == 10
    nmn = load_model("nmn-v3").config
    assert isinstance(nmn, SizeCalibration)
    assert not nmn.size_calibration  # not kept for NMN+: it cost val (the card's table)
