"""From image points to moves: which object a pick point takes, where a place point puts it.

The pick point names the object seen at that pixel in the current segmentation (the
topmost one there). The place point is where the moved object's centre is to appear in
the image: its ray through the known camera is cut with the plane at the height the
object's centre would have on each possible support (the table, or the top face of an
object), and the highest support whose footprint holds the cut point is kept. Pure
geometry on the camera and the current poses: no PyBullet here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.dsl.actions import footprint_half, rests_on
from nsrmp_bench.errors import InvalidAction
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.scene import Pose, SceneObject, State
from nsrmp_bench.vocabulary import TABLE_TOP_Z

__all__ = ["check_point", "picked_object", "place_target"]

F64 = NDArray[np.float64]


def check_point(camera: Camera, point: Sequence[float] | NDArray[np.float64],
                what: str) -> tuple[float, float]:
    """``point`` as ``(u, v)`` pixels, or :class:`InvalidAction` when it is not in the image."""
    try:
        u, v = (float(x) for x in np.asarray(point, dtype=np.float64).reshape(2))
    except (TypeError, ValueError) as exc:
        msg = f"the {what} point must be two numbers (u, v) in pixels, got {point!r}"
        raise InvalidAction(msg) from exc
    if not (math.isfinite(u) and math.isfinite(v)
            and 0.0 <= u <= camera.width and 0.0 <= v <= camera.height):
        msg = (
            f"the {what} point ({u}, {v}) lies outside the {camera.width}x{camera.height} "
            f"image; give u in [0, {camera.width}] and v in [0, {camera.height}] (pixels, "
            "origin at the top-left corner)"
        )
        raise InvalidAction(msg)
    return u, v


def picked_object(segmentation: NDArray[np.int16], point: tuple[float, float]) -> int | None:
    """The object index seen at ``point`` in ``segmentation`` (None: table or background)."""
    h, w = segmentation.shape
    col = min(int(point[0]), w - 1)
    row = min(int(point[1]), h - 1)
    index = int(segmentation[row, col])
    return None if index < 0 else index


def _carried_by(objects: Sequence[SceneObject], state: State, subject: int) -> set[int]:
    """Objects resting on ``subject``, directly or through others."""
    out: set[int] = set()
    frontier = [subject]
    while frontier:
        low = frontier.pop()
        for k in range(len(objects)):
            if k not in out and k != subject and rests_on(objects, state, k, low):
                out.add(k)
                frontier.append(k)
    return out


def place_target(camera: Camera, objects: Sequence[SceneObject], state: State, subject: int,
                 point: tuple[float, float]) -> tuple[Pose, int] | None:
    """The pose ``subject`` gets when placed at image ``point``, and its support (-1: the
    table); None when the point's ray meets no support (above the horizon)."""
    half = objects[subject].extents[2] / 2.0
    carried = _carried_by(objects, state, subject)
    best: tuple[float, F64, int] | None = None
    for j, (obj, pose) in enumerate(zip(objects, state, strict=True)):
        if j == subject or j in carried:
            continue
        top = pose.position[2] + obj.extents[2] / 2.0
        cut = camera.ray_at_height(point, top + half)
        if cut is None:
            continue
        hx, hy, _ = footprint_half(obj, pose)
        on = abs(cut[0] - pose.position[0]) <= hx and abs(cut[1] - pose.position[1]) <= hy
        if on and (best is None or top > best[0]):
            best = (top, cut, j)
    if best is None:
        cut = camera.ray_at_height(point, TABLE_TOP_Z + half)
        if cut is None:
            return None
        best = (TABLE_TOP_Z, cut, -1)
    _, cut, support = best
    pose = Pose((float(cut[0]), float(cut[1]), float(best[0] + half)),
                state[subject].orientation)
    return pose, support
