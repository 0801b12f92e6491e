"""The network's inputs for one step, all non-learned and inspectable (numpy only).

For a step that moves objects ``moved`` from boxes ``old`` to boxes ``new``:

- **plate**: the empty scene (table and robot, no objects) as the camera sees it: the
  per-pixel median of training images (:func:`~.data.background_plate`), part of the
  checkpoint, read off renders, not made by a simulator;
- **masks**: the old and the new boxes rasterised (each grown by ``margin`` pixels);
- **composite**: the image before the step with the object pixels of every old box (those
  that differ from the plate by more than ``FOREGROUND_THRESHOLD``) replaced by the plate,
  and those object pixels resized (nearest neighbour) into the new box; the network
  corrects this image;
- **region**: the union of the two masks; outside it the output *is* the image before the
  step, so the network only ever paints inside the boxes a step moved.

Which objects a step moved is read off the boxes alone (:func:`moved_objects`), so any
predictions file with ``step_boxes`` works, whatever model wrote it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.geometry.boxes import MOVE_TOLERANCE, moved_objects

__all__ = ["MOVE_TOLERANCE", "box_mask", "composite", "moved_objects", "step_inputs"]

U8 = NDArray[np.uint8]
F64 = NDArray[np.float64]

INPUT_CHANNELS = 11  # composite (3), before (3), plate (3), old mask, new mask

FOREGROUND_THRESHOLD = 16
"""Grey levels: a pixel of a box is the object's where some channel differs from the plate
by more than this (the table renders the same in every scene)."""


def _pixel_box(box: NDArray[Any], margin: float, height: int, width: int
               ) -> tuple[int, int, int, int]:
    x0, y0, x1, y1 = (float(v) for v in box)
    return (int(np.clip(np.floor(x0 - margin), 0, width)),
            int(np.clip(np.floor(y0 - margin), 0, height)),
            int(np.clip(np.ceil(x1 + margin), 0, width)),
            int(np.clip(np.ceil(y1 + margin), 0, height)))


def box_mask(boxes: NDArray[Any], height: int, width: int, margin: float = 0.0
             ) -> NDArray[np.bool_]:
    """Pixels covered by any of ``boxes`` (``(K, 4)`` xyxy) grown by ``margin``."""
    mask = np.zeros((height, width), dtype=bool)
    for box in np.asarray(boxes, np.float64).reshape(-1, 4):
        x0, y0, x1, y1 = _pixel_box(box, margin, height, width)
        mask[y0:y1, x0:x1] = True
    return mask


def _foreground(image: U8, plate: U8) -> NDArray[np.bool_]:
    diff = np.abs(image.astype(np.int16) - plate.astype(np.int16)).max(axis=-1)
    out: NDArray[np.bool_] = diff > FOREGROUND_THRESHOLD
    return out


def composite(before: U8, old: NDArray[Any], new: NDArray[Any], plate: U8) -> U8:
    """``before`` with each old box's object pixels emptied (the plate shows through) and
    pasted, resized to the matching new box, over the result."""
    h, w = before.shape[:2]
    if plate.shape != before.shape:
        msg = f"the plate is {plate.shape}, the image {before.shape}; they must match"
        raise ValueError(msg)
    out = before.copy()
    fg = _foreground(before, plate)
    crops = []
    for box in np.asarray(old, np.float64).reshape(-1, 4):
        x0, y0, x1, y1 = _pixel_box(box, 0.0, h, w)
        crops.append((before[y0:y1, x0:x1].copy(), fg[y0:y1, x0:x1].copy()))
        sel = fg[y0:y1, x0:x1]
        out[y0:y1, x0:x1][sel] = plate[y0:y1, x0:x1][sel]
    for (crop, mask), box in zip(crops, np.asarray(new, np.float64).reshape(-1, 4),
                                 strict=True):
        x0, y0, x1, y1 = _pixel_box(box, 0.0, h, w)
        if x1 <= x0 or y1 <= y0 or crop.size == 0:
            continue
        # sample the crop at the new box's pixels (a box clipped by the image keeps its scale)
        bx0, by0, bx1, by1 = (float(v) for v in box)
        sx = (np.arange(x0, x1) + 0.5 - bx0) / max(bx1 - bx0, 1e-6) * crop.shape[1]
        sy = (np.arange(y0, y1) + 0.5 - by0) / max(by1 - by0, 1e-6) * crop.shape[0]
        ix = np.clip(sx.astype(np.int64), 0, crop.shape[1] - 1)
        iy = np.clip(sy.astype(np.int64), 0, crop.shape[0] - 1)
        pasted, sel = crop[iy[:, None], ix[None, :]], mask[iy[:, None], ix[None, :]]
        out[y0:y1, x0:x1][sel] = pasted[sel]
    return out


def step_inputs(before: U8, old: NDArray[Any], new: NDArray[Any], plate: U8, *,
                margin: int) -> U8:
    """The network's input ``(11, H, W)`` uint8: composite, before, plate, old mask, new
    mask."""
    h, w = before.shape[:2]
    comp = composite(before, old, new, plate)
    m_old = box_mask(old, h, w, margin).astype(np.uint8) * 255
    m_new = box_mask(new, h, w, margin).astype(np.uint8) * 255
    out: U8 = np.concatenate([comp.transpose(2, 0, 1), before.transpose(2, 0, 1),
                              plate.transpose(2, 0, 1), m_old[None], m_new[None]], axis=0)
    return out
