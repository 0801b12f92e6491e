"""Axis-aligned 2D boxes in pixel ``xyxy``: areas, IoU, centres and point tests.

Every function is vectorised over leading dimensions: a box array has shape ``(..., 4)``
holding ``x1, y1, x2, y2`` with ``x1 <= x2`` and ``y1 <= y2`` (pixel coordinates, (0, 0)
the top-left corner of the image). Nothing here validates input; the submission
validator does that before scoring.

IoU of two boxes whose union has zero area (both degenerate) is 1 when the boxes are
identical and 0 otherwise, so a perfect prediction of a degenerate gold box scores 1.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["MOVE_TOLERANCE", "box_area", "box_centres", "box_intersection", "box_iou",
           "moved_objects", "points_in_boxes"]

MOVE_TOLERANCE = 1.0
"""Pixels: an object moved in a step when a corner of its box moved by more than this."""

F64 = NDArray[np.float64]


def box_area(boxes: NDArray[Any]) -> F64:
    """Area ``(...)`` of boxes ``(..., 4)``; negative widths or heights count as zero."""
    b = np.asarray(boxes, dtype=np.float64)
    w = np.clip(b[..., 2] - b[..., 0], 0.0, None)
    h = np.clip(b[..., 3] - b[..., 1], 0.0, None)
    out: F64 = np.asarray(w * h, dtype=np.float64)
    return out


def box_intersection(a: NDArray[Any], b: NDArray[Any]) -> F64:
    """Area ``(...)`` of the intersection of paired boxes ``a`` and ``b`` (broadcast)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    w = np.minimum(a[..., 2], b[..., 2]) - np.maximum(a[..., 0], b[..., 0])
    h = np.minimum(a[..., 3], b[..., 3]) - np.maximum(a[..., 1], b[..., 1])
    out: F64 = np.asarray(np.clip(w, 0.0, None) * np.clip(h, 0.0, None), dtype=np.float64)
    return out


def box_iou(a: NDArray[Any], b: NDArray[Any]) -> F64:
    """Intersection over union ``(...)`` of paired boxes ``a`` and ``b`` (broadcast).

    Both degenerate (zero-area union): 1 if the boxes are equal, else 0.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    inter = box_intersection(a, b)
    union = box_area(a) + box_area(b) - inter
    positive = union > 0.0
    safe = np.where(positive, union, 1.0)
    same = np.all(a == b, axis=-1)
    out: F64 = np.where(positive, inter / safe, np.where(same, 1.0, 0.0))
    return out


def box_centres(boxes: NDArray[Any]) -> F64:
    """Centres ``(..., 2)`` (x, y) of boxes ``(..., 4)``: the mean of both corners."""
    b = np.asarray(boxes, dtype=np.float64)
    return np.stack([(b[..., 0] + b[..., 2]) / 2.0, (b[..., 1] + b[..., 3]) / 2.0], axis=-1)


def points_in_boxes(points: NDArray[Any], boxes: NDArray[Any]) -> NDArray[np.bool_]:
    """Whether each point ``(..., 2)`` lies in its box ``(..., 4)``, borders included.

    A NaN point lies in no box.
    """
    p = np.asarray(points, dtype=np.float64)
    b = np.asarray(boxes, dtype=np.float64)
    inside: NDArray[np.bool_] = (
        (p[..., 0] >= b[..., 0])
        & (p[..., 0] <= b[..., 2])
        & (p[..., 1] >= b[..., 1])
        & (p[..., 1] <= b[..., 3])
    )
    return inside


def moved_objects(before: NDArray[Any], after: NDArray[Any],
                  tol: float = MOVE_TOLERANCE) -> NDArray[np.int64]:
    """Indices of the objects whose box (``(N, 4)`` xyxy) changed by more than ``tol``."""
    diff = np.abs(np.asarray(after, np.float64) - np.asarray(before, np.float64)).max(axis=1)
    out: NDArray[np.int64] = np.nonzero(diff > tol)[0].astype(np.int64)
    return out
