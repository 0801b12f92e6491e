"""Image-space targets of one rendered state: amodal and visible boxes, visibility, depth.

* **amodal box**: :meth:`Camera.amodal_boxes` of the object's settled 3D box.
* **visible box**: the pixel extent of the object's segmentation mask, pixel ``xyxy``
  with the right/bottom edges exclusive (a single pixel (i, j) gives ``[j, i, j+1, i+1]``);
  NaN when no pixel is seen.
* **visible fraction**: mask pixels / area of the object's silhouette, the convex hull of
  its projected outline points (:func:`silhouette_points`) clipped to the image. For the
  box-shaped cube and dice the hull *is* the silhouette, so an unoccluded object scores
  1 up to the rasterisation of its edges; for the lego the hull bridges the notches
  between studs, so an unoccluded brick scores slightly below 1 (~0.97). No object is
  rendered alone. Clipped to [0, 1].
* **exposed fraction** (used to reject instances, not stored): mask pixels / area of the
  silhouette *not covered by the objects stacked on the object*. An object under a
  stack is hidden by its own load as a matter of course; what must not happen is that
  something else hides it.
* **centre depth**: optical-axis depth (metres) of the 3D box centre.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require
from nsrmp_bench.generators.world.assets import silhouette_points
from nsrmp_bench.geometry.camera import Camera, quaternion_matrices
from nsrmp_bench.scene import SceneObject

__all__ = [
    "FrameTargets",
    "frame_targets",
    "silhouette_areas",
    "stacked_above",
    "visible_boxes",
]

F32 = NDArray[np.float32]


@dataclass(frozen=True, eq=False)
class FrameTargets:
    """Targets of one rendered state for N objects."""

    boxes_amodal: F32  # (N, 4)
    boxes_visible: F32  # (N, 4), NaN where unseen
    visible_fraction: F32  # (N,)
    visible_pixels: NDArray[np.int64]  # (N,)
    silhouette_area: F32  # (N,) pixels
    exposed_fraction: F32  # (N,) visible pixels / silhouette pixels not under its stack
    depth_centre: F32  # (N,)


@cache
def _outline(shape: str) -> NDArray[np.float64]:
    pts: NDArray[np.float64] = np.asarray(silhouette_points(shape), dtype=np.float64)
    return pts


def _hulls(
    camera: Camera, shapes: Sequence[str], poses: NDArray[np.float64],
    rot: NDArray[np.float64] | None = None,
) -> list[NDArray[np.float32] | None]:
    cv2 = require("cv2")
    out: list[NDArray[np.float32] | None] = [None] * len(shapes)
    if not len(shapes):
        return out
    if rot is None:
        rot = quaternion_matrices(poses[:, 3:7])
    for shape in sorted(set(shapes)):
        idx = [i for i, s in enumerate(shapes) if s == shape]
        pts = np.einsum("nij,pj->npi", rot[idx], _outline(shape)) + poses[idx, None, :3]
        uv, z = camera.project(pts)
        for row, i in enumerate(idx):
            if not (z[row] <= camera.near).any():
                out[i] = cv2.convexHull(uv[row].astype(np.float32))
    return out


def silhouette_areas(
    camera: Camera, shapes: Sequence[str], poses: NDArray[np.float64]
) -> NDArray[np.float32]:
    """Area in pixels of each object's projected silhouette hull, clipped to the image."""
    return _areas(camera, _hulls(camera, shapes, poses))


def _areas(camera: Camera, hulls: Sequence[NDArray[np.float32] | None]) -> NDArray[np.float32]:
    cv2 = require("cv2")
    rect = np.array([[0.0, 0.0], [camera.width, 0.0], [camera.width, camera.height],
                     [0.0, camera.height]], dtype=np.float32)
    out = np.zeros(len(hulls), dtype=np.float32)
    for i, hull in enumerate(hulls):
        if hull is not None:
            area, _ = cv2.intersectConvexConvex(hull, rect)
            out[i] = max(float(area), 0.0)
    return out


_SUB = 4  # sub-pixel bits for cv2 polygon filling


def stacked_above(poses: NDArray[np.float64], *, xy_tol: float = 0.025,
                  z_gap: float = 0.02) -> list[list[int]]:
    """For each object, the objects resting above it in its stack (centres within
    ``xy_tol`` horizontally and more than ``z_gap`` higher)."""
    pos = poses[:, :3]
    dxy = np.linalg.norm(pos[:, None, :2] - pos[None, :, :2], axis=-1)
    dz = pos[None, :, 2] - pos[:, None, 2]
    over = (dxy < xy_tol) & (dz > z_gap)
    return [list(np.flatnonzero(row)) for row in over]


def _exposed_areas(
    camera: Camera,
    hulls: Sequence[NDArray[np.float32] | None],
    areas: NDArray[np.float32],
    above: Sequence[Sequence[int]],
) -> NDArray[np.float32]:
    """Silhouette pixels of each object not covered by the silhouettes stacked on it."""
    cv2 = require("cv2")
    out = areas.copy()
    scale = float(1 << _SUB)
    for i, others in enumerate(above):
        hull = hulls[i]
        if not others or hull is None:
            continue
        pts = hull.reshape(-1, 2)
        x0 = max(int(np.floor(pts[:, 0].min())) - 1, 0)
        y0 = max(int(np.floor(pts[:, 1].min())) - 1, 0)
        x1 = min(int(np.ceil(pts[:, 0].max())) + 1, camera.width)
        y1 = min(int(np.ceil(pts[:, 1].max())) + 1, camera.height)
        if x1 <= x0 or y1 <= y0:
            out[i] = 0.0
            continue
        canvas = np.zeros((y1 - y0, x1 - x0), dtype=np.uint8)
        shift = np.array([x0 + 0.5, y0 + 0.5], dtype=np.float32)  # pixel centres
        own = np.round((pts - shift) * scale).astype(np.int32)
        cv2.fillConvexPoly(canvas, own, 1, cv2.LINE_8, _SUB)
        full = int(np.count_nonzero(canvas))
        for j in others:
            hj = hulls[j]
            if hj is not None:
                poly = np.round((hj.reshape(-1, 2) - shift) * scale).astype(np.int32)
                cv2.fillConvexPoly(canvas, poly, 0, cv2.LINE_8, _SUB)
        left = int(np.count_nonzero(canvas))
        out[i] = areas[i] * (left / full) if full else 0.0
    return out


def visible_boxes(
    segmentation: NDArray[np.int16], n: int
) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
    """Mask extents ``(n, 4)`` pixel xyxy (NaN if unseen) and pixel counts ``(n,)``."""
    w = segmentation.shape[1]
    flat = segmentation.reshape(-1)
    idx = np.flatnonzero(flat >= 0)
    labels = flat[idx].astype(np.int64)
    counts = np.bincount(labels, minlength=n)[:n]
    boxes = np.full((n, 4), np.nan, dtype=np.float32)
    if idx.size:
        order = np.argsort(labels, kind="stable")
        labels = labels[order]
        idx = idx[order]
        rows = idx // w
        cols = idx % w
        starts = np.flatnonzero(np.r_[True, labels[1:] != labels[:-1]])
        present = labels[starts]
        keep = present < n
        starts_k = starts[keep]
        present = present[keep]
        # columns: min/max per label (rows are already sorted within a label by idx order)
        boxes[present, 0] = np.minimum.reduceat(cols, starts)[keep]
        boxes[present, 2] = np.maximum.reduceat(cols, starts)[keep] + 1
        boxes[present, 1] = rows[starts_k]
        ends = np.r_[starts[1:], labels.size][keep] - 1
        boxes[present, 3] = rows[ends] + 1
    return boxes, counts.astype(np.int64)


def frame_targets(
    camera: Camera,
    objects: Sequence[SceneObject],
    poses: NDArray[np.float64],
    segmentation: NDArray[np.int16],
) -> FrameTargets:
    """All image-space targets of one state: ``poses`` ``(N, 7)`` are the settled poses
    the image was rendered from, ``segmentation`` its object-index mask."""
    n = len(objects)
    extents = np.array([o.extents for o in objects], dtype=np.float64).reshape(n, 3)
    rot = quaternion_matrices(poses[:, 3:7]) if n else np.zeros((0, 3, 3))
    amodal = camera.amodal_boxes(extents, poses[:, :3], poses[:, 3:7], rotations=rot)
    visible, counts = visible_boxes(segmentation, n)
    hulls = _hulls(camera, [o.shape for o in objects], poses, rot)
    areas = _areas(camera, hulls)
    exposed = _exposed_areas(camera, hulls, areas, stacked_above(poses))
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(areas > 0, counts / np.maximum(areas, 1e-9), 0.0)
        exp_frac = np.where(exposed > 0, counts / np.maximum(exposed, 1e-9), 0.0)
    frac = np.clip(frac, 0.0, 1.0).astype(np.float32)
    exp_frac = np.clip(exp_frac, 0.0, 1.0).astype(np.float32)
    _, depth = camera.project(poses[:, :3])
    return FrameTargets(
        boxes_amodal=amodal.astype(np.float32),
        boxes_visible=visible,
        visible_fraction=frac,
        visible_pixels=counts,
        silhouette_area=areas,
        exposed_fraction=exp_frac,
        depth_centre=np.asarray(depth, dtype=np.float32).reshape(n),
    )
