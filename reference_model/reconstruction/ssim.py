"""SSIM of a reconstructed image against the simulator's render, over the whole image and
inside a region (scikit-image's ``structural_similarity``; no hand-written SSIM).

Both figures come from one SSIM map (7x7 uniform window, data range 255, the mean over the
three colour channels): the whole-image figure is the map's mean (skimage's own mean SSIM),
the region figure its mean over the region's pixels. The static background inflates the
first; the second, over the boxes a step moved, is the honest one.
"""

from __future__ import annotations

from types import ModuleType

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require

__all__ = ["ssim_map", "ssim_scores"]


def ssim_map(pred: NDArray[np.uint8], gold: NDArray[np.uint8]) -> NDArray[np.float64]:
    """Per-pixel SSIM ``(H, W)`` of two RGB uint8 images of one size."""
    metrics: ModuleType = require("skimage.metrics")
    if pred.shape != gold.shape:
        msg = f"SSIM needs two images of one size, got {pred.shape} and {gold.shape}"
        raise ValueError(msg)
    _, full = metrics.structural_similarity(gold, pred, channel_axis=2, data_range=255,
                                            full=True)
    out: NDArray[np.float64] = np.asarray(full, np.float64).mean(axis=2)
    return out


def ssim_scores(pred: NDArray[np.uint8], gold: NDArray[np.uint8],
                region: NDArray[np.bool_]) -> tuple[float, float]:
    """(whole-image SSIM, SSIM inside ``region``; NaN when the region is empty)."""
    m = ssim_map(pred, gold)
    inside = float(m[region].mean()) if region.any() else float("nan")
    return float(m.mean()), inside
