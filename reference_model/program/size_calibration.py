"""The perception's size calibration: each scene's object sizes read at the scale of the
scenes the networks were trained on.

A program model's perception reads each object's estimated width and height in metres
beside its crop (``object_sizes``): a lego brick is about a quarter larger than a cube or a
die, and the crop alone, resized to a square, has lost that. Another renderer or camera
changes the estimate for every object of a scene at once (the original authors' generator:
about 12% smaller), and the size then names the wrong shape: its lego bricks come out as
high as our cubes. The calibration undoes a common scale per scene, from the scene's own
inputs only:

- a **size prior**, fitted without labels on a training-side part's initial boxes and
  depths (:func:`fit_size_prior`: a two-component Gaussian mixture of (width, height),
  diagonal, by expectation-maximisation from the smallest and largest objects), is the
  distribution of sizes the networks saw;
- for each scene the scale ``s`` on a grid between ``scale_low`` and ``scale_high`` that
  makes the scene's sizes most likely under the prior, with a log-normal prior on ``s``
  (``scale_spread``), is chosen (:func:`scene_scale`) only when it is more likely than
  ``s = 1`` by ``scale_evidence`` nats: a scene of the training kind keeps its sizes.

Only what the perception reads is scaled; the action rule keeps the estimated sizes (where
an object lands depends on how big it is). Nothing here reads a label.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from torch import Tensor

from nsrmp_bench.reference_model.program.scene3d import SceneState

__all__ = ["SizeCalibration", "SizePrior", "calibrated_sizes", "fit_size_prior",
           "part_sizes", "scene_scale"]

_COMPONENT = 5  # mean width, mean height, spread width, spread height, weight


@dataclass(frozen=True)
class SizeCalibration:
    """The calibration's settings (fields of the v3 configs)."""

    size_calibration: bool = True
    size_prior: tuple[float, ...] = ()  # fit_size_prior(...).values(); empty: no calibration
    scale_low: float = 0.8
    scale_high: float = 1.25
    scale_steps: int = 37
    scale_spread: float = 0.1  # sd of log(scale) in the prior on the scale
    scale_evidence: float = 3.0  # nats over scale 1 before a scene is rescaled


@dataclass(frozen=True)
class SizePrior:
    """A Gaussian mixture over (width, height) in metres, diagonal: ``means`` (K, 2),
    ``spreads`` (K, 2), ``weights`` (K,)."""

    means: NDArray[np.float64]
    spreads: NDArray[np.float64]
    weights: NDArray[np.float64]

    def values(self) -> tuple[float, ...]:
        """Flat form for a config: per component mean w, mean h, spread w, spread h, weight."""
        rows = np.concatenate([self.means, self.spreads, self.weights[:, None]], 1)
        return tuple(round(float(v), 6) for v in rows.reshape(-1))

    @classmethod
    def from_values(cls, values: Sequence[float]) -> SizePrior:
        """Inverse of :meth:`values`."""
        if not values or len(values) % _COMPONENT:
            msg = (f"a size prior has {_COMPONENT} values per component (mean w, mean h, "
                   f"spread w, spread h, weight), got {len(values)}: write it with "
                   f"fit_size_prior(...).values()")
            raise ValueError(msg)
        rows = np.asarray(values, dtype=np.float64).reshape(-1, _COMPONENT)
        return cls(rows[:, :2], rows[:, 2:4], rows[:, 4])

    def components(self, sizes: NDArray[np.float64]) -> NDArray[np.float64]:
        """log (weight x density) of each component for each row of ``sizes`` (..., 2):
        (..., K)."""
        z = (sizes[..., None, :] - self.means) / self.spreads
        out: NDArray[np.float64] = (-0.5 * (z**2).sum(-1) - np.log(self.spreads).sum(-1)
                                    - np.log(2 * np.pi) + np.log(self.weights))
        return out

    def log_likelihood(self, sizes: NDArray[np.float64]) -> NDArray[np.float64]:
        """log p of each row of ``sizes`` (..., 2)."""
        out: NDArray[np.float64] = np.logaddexp.reduce(self.components(sizes), axis=-1)
        return out


def fit_size_prior(sizes: NDArray[Any], iterations: int = 100) -> SizePrior:
    """Two-component mixture fitted to ``sizes`` (M, 2) by expectation-maximisation,
    started from the smallest and the largest third (deterministic, no labels)."""
    x = np.asarray(sizes, dtype=np.float64).reshape(-1, 2)
    if len(x) < 10:
        msg = f"a size prior needs at least 10 objects' sizes, got {len(x)}: fit it on a part"
        raise ValueError(msg)
    order = np.argsort(x.sum(1), kind="stable")
    third = len(x) // 3
    parts = (x[order[:third]], x[order[-third:]])
    prior = SizePrior(np.stack([p.mean(0) for p in parts]),
                      np.stack([p.std(0) + 1e-4 for p in parts]), np.array([0.5, 0.5]))
    for _ in range(iterations):
        comp = prior.components(x)
        resp = np.exp(comp - np.logaddexp.reduce(comp, axis=1, keepdims=True))
        mass = resp.sum(0)
        means = (resp.T @ x) / mass[:, None]
        var = (resp.T @ x**2) / mass[:, None] - means**2
        prior = SizePrior(means, np.sqrt(np.maximum(var, 1e-8)), mass / mass.sum())
    return prior


def scene_scale(sizes: NDArray[Any], prior: SizePrior, settings: SizeCalibration) -> float:
    """The scale at which a scene's sizes (N, 2) are read (see the module doc)."""
    x = np.asarray(sizes, dtype=np.float64).reshape(-1, 2)
    if len(x) == 0:
        return 1.0
    grid = np.exp(np.linspace(np.log(settings.scale_low), np.log(settings.scale_high),
                              settings.scale_steps))

    def score(s: float) -> float:
        return float(prior.log_likelihood(x * s).sum() - 0.5 * (np.log(s)
                                                               / settings.scale_spread) ** 2)

    scores = [score(float(s)) for s in grid]
    best = int(np.argmax(scores))
    return float(grid[best]) if scores[best] - score(1.0) > settings.scale_evidence else 1.0


def calibrated_sizes(sizes: Tensor, mask: Tensor, prior: SizePrior,
                     settings: SizeCalibration) -> Tensor:
    """``sizes`` (B, N, 2) with each scene's objects (``mask`` (B, N)) at its scale."""
    out = sizes.clone()
    for b in range(sizes.shape[0]):
        m = mask[b]
        s = scene_scale(sizes[b][m].double().numpy(), prior, settings)
        if s != 1.0:
            out[b][m] = sizes[b][m] * s
    return out


def part_sizes(states: Sequence[SceneState]) -> NDArray[np.float64]:
    """Every object's (width, height) of a part's scene states."""
    rows = [np.stack([s.sizes, s.heights], 1) for s in states if len(s)]
    return np.concatenate(rows) if rows else np.zeros((0, 2))

