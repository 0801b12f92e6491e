"""Matching detected boxes to gold boxes: pairwise IoU and the Hungarian assignment.

One place for the matching that the detection metrics (missed and merged objects), the
detected-objects scorer protocol and the detector's in-loop validation all use. The
assignment maximises total IoU (``scipy.optimize.linear_sum_assignment``); a pair below the
threshold is not a match.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require

__all__ = ["MATCH_IOU", "hungarian_match", "pairwise_iou"]

MATCH_IOU = 0.5
"""A detection matches a gold object when their boxes' IoU is at least this."""


def pairwise_iou(a: NDArray[Any], b: NDArray[Any]) -> NDArray[np.float64]:
    """(len(a), len(b)) IoU of pixel xyxy boxes (0 where the union is empty)."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    x1 = np.maximum(a[:, None, 0], b[None, :, 0])
    y1 = np.maximum(a[:, None, 1], b[None, :, 1])
    x2 = np.minimum(a[:, None, 2], b[None, :, 2])
    y2 = np.minimum(a[:, None, 3], b[None, :, 3])
    inter = np.clip(x2 - x1, 0, None) * np.clip(y2 - y1, 0, None)
    area_a = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    area_b = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    union = area_a[:, None] + area_b[None, :] - inter
    out: NDArray[np.float64] = np.where(union > 0, inter / np.where(union > 0, union, 1), 0.0)
    return out


def hungarian_match(gold: NDArray[Any], detected: NDArray[Any],
                    threshold: float = MATCH_IOU) -> NDArray[np.int64]:
    """For each gold box, the index of its detection, or -1 when none matches.

    Maximum-total-IoU one-to-one assignment; pairs with IoU below ``threshold`` are
    dropped from it. Needs scipy (the ``detection`` extra).
    """
    opt = require("scipy.optimize")
    iou = pairwise_iou(gold, detected)
    out = np.full(iou.shape[0], -1, dtype=np.int64)
    if iou.size == 0:
        return out
    rows, cols = opt.linear_sum_assignment(iou, maximize=True)
    ok = iou[rows, cols] >= threshold
    out[rows[ok]] = cols[ok]
    return out
