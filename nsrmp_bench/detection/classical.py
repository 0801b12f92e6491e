"""The classical depth-and-colour detector (``classical-v1``): no learning, no torch.

The pipeline of ``reference/nsrm-original-model.md`` §6.4, on our renders:

1. **Foreground**: pixels whose world point (depth back-projected through the camera) lies
   over the workspace where objects are placed (``TARGET_AREA`` widened by ``MARGIN``:
   the robot's base stands beyond it), between ``MIN_HEIGHT`` and ``MAX_HEIGHT`` above
   the table top (the floor lies below it, the robot's gripper above).
2. **Colour**: each foreground pixel takes the nearest of the seven object colours by
   hue, or white when unsaturated and bright; dark pixels (dice pips, edges in shade) take
   none.
3. **Components**: per colour, the mask's holes are filled (pips), a 3x3 opening drops
   speckle, and its 8-connected components are the objects; components under
   ``MIN_PIXELS`` are dropped.
4. **Boxes**: each component's tight box, widened by ``PAD`` px on each side (the scored
   boxes are amodal: the projection of the 3D box, slightly larger than the silhouette).

It sees colour but not shape (``shapes`` are null). Known failures: same-colour touching
or stacked objects merge into one detection; an object hidden behind another of the same
colour merges with it. Needs scipy (the ``detection`` extra).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require
from nsrmp_bench.detection.detections import Detections
from nsrmp_bench.detection.height import world_points
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.vocabulary import COLOUR_RGBA, COLOURS, TABLE_TOP_Z, TARGET_AREA

__all__ = ["CLASSICAL_ID", "classical_detect"]

CLASSICAL_ID = "classical-v1"
MIN_HEIGHT = 0.006  # metres above the table
MAX_HEIGHT = 0.16
MARGIN = 0.08  # metres around the object-centre area (an object's half size and more)
MIN_PIXELS = 20
PAD = 1.0
_WHITE_SAT = 0.3
_WHITE_VAL = 0.55
_DARK_VAL = 0.18
_SAT_MIN = 0.3


def _hsv(rgb: NDArray[Any]) -> tuple[NDArray[np.float64], ...]:
    x = np.asarray(rgb, dtype=np.float64) / 255.0
    mx, mn = x.max(-1), x.min(-1)
    d = mx - mn
    sat = np.where(mx > 0, d / np.where(mx > 0, mx, 1), 0.0)
    safe = np.where(d > 0, d, 1.0)
    r, g, b = x[..., 0], x[..., 1], x[..., 2]
    hue = np.where(mx == r, ((g - b) / safe) % 6, np.where(mx == g, (b - r) / safe + 2,
                                                           (r - g) / safe + 4)) * 60.0
    return hue, sat, mx


_REF = np.array([COLOUR_RGBA[c][:3] for c in COLOURS]) * 255.0
_REF_HUE, _, _ = _hsv(_REF)
_CHROMATIC = [i for i, c in enumerate(COLOURS) if c != "white"]
_WHITE = COLOURS.index("white")


def _labels(rgb: NDArray[Any], fg: NDArray[np.bool_]) -> NDArray[np.int64]:
    """Per pixel the colour index, or -1 (background, dark, or unsaturated and dim)."""
    hue, sat, val = _hsv(rgb)
    dist = np.abs(hue[..., None] - _REF_HUE[_CHROMATIC])
    dist = np.minimum(dist, 360.0 - dist)
    chroma = np.asarray(_CHROMATIC)[dist.argmin(-1)]
    out = np.full(fg.shape, -1, dtype=np.int64)
    coloured = fg & (sat >= _SAT_MIN) & (val > _DARK_VAL)
    white = fg & (sat < _WHITE_SAT) & (val >= _WHITE_VAL)
    out[coloured] = chroma[coloured]
    out[white & ~coloured] = _WHITE
    return out


def classical_detect(episode_id: str, rgb: NDArray[Any], depth: NDArray[Any],
                     camera: Camera) -> Detections:
    """The detections of one initial scene."""
    nd = require("scipy.ndimage")
    pts = world_points(depth, camera)
    height = pts[..., 2] - TABLE_TOP_Z
    a = TARGET_AREA
    fg = ((height >= MIN_HEIGHT) & (height <= MAX_HEIGHT)
          & (pts[..., 0] >= a.x_min - MARGIN) & (pts[..., 0] <= a.x_max + MARGIN)
          & (pts[..., 1] >= a.y_min - MARGIN) & (pts[..., 1] <= a.y_max + MARGIN))
    h, w = fg.shape
    boxes: list[list[float]] = []
    scores: list[float] = []
    colours: list[str] = []
    ys, xs = np.nonzero(fg)
    if len(ys) == 0:
        return Detections(episode_id, np.zeros((0, 4)), np.zeros(0), (), ())
    # work inside the foreground's bounding box with a 2 px background margin: the same
    # components as on the whole image (the margin keeps holes and openings unchanged)
    y0, x0 = max(0, int(ys.min()) - 2), max(0, int(xs.min()) - 2)
    y1, x1 = min(h, int(ys.max()) + 3), min(w, int(xs.max()) + 3)
    labels = np.full((y1 - y0 + 4, x1 - x0 + 4), -1, dtype=np.int64)
    labels[2:-2, 2:-2] = _labels(rgb[y0:y1, x0:x1], fg[y0:y1, x0:x1])
    ox, oy = x0 - 2, y0 - 2
    present = set(np.unique(labels).tolist())
    for ci, colour in enumerate(COLOURS):
        if ci not in present:
            continue
        mask = nd.binary_fill_holes(labels == ci)
        mask = nd.binary_opening(mask, structure=np.ones((3, 3), bool))
        comp, n = nd.label(mask, structure=np.ones((3, 3), int))
        if n == 0:
            continue
        for k, sl in enumerate(nd.find_objects(comp), start=1):
            if sl is None:
                continue
            area = int((comp[sl] == k).sum())
            if area < MIN_PIXELS:
                continue
            sy, sx = sl
            boxes.append([max(0.0, sx.start + ox - PAD), max(0.0, sy.start + oy - PAD),
                          min(float(w), sx.stop + ox + PAD), min(float(h), sy.stop + oy + PAD)])
            # confidence grows with the component's size (a speckle is doubtful)
            scores.append(float(min(1.0, area / 200.0)))
            colours.append(colour)
    order = np.argsort(-np.asarray(scores), kind="stable")
    return Detections(episode_id, np.asarray(boxes, dtype=np.float64).reshape(-1, 4)[order],
                      np.asarray(scores, dtype=np.float64)[order],
                      (None,) * len(order), tuple(colours[i] for i in order))
