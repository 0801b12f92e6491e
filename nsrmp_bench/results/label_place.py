"""Labels inside a figure's axes placed where no data is drawn.

A figure's labels (a reference row's name at its line, a reference off the scale, the
"train range" / "held out" marks) are created with :func:`movable`; :func:`place_labels`
then lays the figure out once, freezes that layout, and moves each movable label
vertically, as little as it can, until it overprints no data line, marker, bar or other
label. The figure's bytes stay a function of its data (no randomness, a fixed search
order).
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

import numpy as np

from nsrmp_bench._optional import require

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.backend_bases import RendererBase
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.text import Text
    from matplotlib.transforms import Bbox
    from numpy.typing import NDArray

__all__ = ["GID", "label_overlaps", "movable", "place_labels"]

GID = "nsrmp-movable-label"
"""The ``gid`` of a text :func:`place_labels` may move."""

PAD_PX = 2.0
"""Clear space kept around a label, in pixels of the figure's own dpi."""


def movable(text: Text, own: Line2D | None = None) -> Text:
    """Mark ``text`` (a matplotlib ``Text`` in axes coordinates) as free to move; ``own``
    is the line it labels, the one line it may sit on."""
    text.set_gid(GID)
    text.nsrmp_own_line = own  # type: ignore[attr-defined]  # a mark of ours
    return text


def _line_points(ax: Axes, skip: Line2D | None = None) -> NDArray[np.float64]:
    """Display-space points along every data line of ``ax`` (segments sampled every
    pixel), each with the clearance it needs (half the line width, or the marker's radius
    at a vertex). Returns an (n, 3) array: x, y, clearance."""
    dpi = ax.figure.dpi
    out = [np.zeros((0, 3))]
    for line in ax.get_lines():
        if line is skip:
            continue
        xy = np.asarray(line.get_xydata(), dtype=float)
        if xy.size == 0 or not line.get_visible():
            continue
        pts = line.get_transform().transform(xy)
        pts = pts[np.isfinite(pts).all(axis=1)]
        if len(pts) == 0:
            continue
        width = line.get_linewidth() * dpi / 72.0 / 2.0
        marker = line.get_markersize() * dpi / 72.0 / 2.0 if line.get_marker() not in (
            None, "None", "", " ") else 0.0
        if line.get_linestyle() not in ("None", "", " ") and len(pts) > 1:
            for a, b in itertools.pairwise(pts):
                n = max(2, int(np.hypot(*(b - a))) + 1)
                t = np.linspace(0.0, 1.0, n)[:, None]
                seg = a + t * (b - a)
                out.append(np.column_stack([seg, np.full(len(seg), width)]))
        if marker:
            out.append(np.column_stack([pts, np.full(len(pts), marker)]))
    return np.concatenate(out)


def _boxes(ax: Axes, renderer: RendererBase) -> list[Bbox]:
    """Bars (and any other patch of the axes) as display-space boxes."""
    return [p.get_window_extent(renderer) for p in ax.patches if p.get_visible()]


def _hits(box: Bbox, points: NDArray[np.float64], obstacles: list[Bbox]) -> bool:
    x0, y0, x1, y1 = box.x0 - PAD_PX, box.y0 - PAD_PX, box.x1 + PAD_PX, box.y1 + PAD_PX
    if len(points):
        c = points[:, 2]
        inside = ((points[:, 0] >= x0 - c) & (points[:, 0] <= x1 + c)
                  & (points[:, 1] >= y0 - c) & (points[:, 1] <= y1 + c))
        if inside.any():
            return True
    return any(o.x0 < x1 and o.x1 > x0 and o.y0 < y1 and o.y1 > y0 for o in obstacles)


def label_overlaps(fig: Figure) -> list[str]:
    """The texts of ``fig``'s axes that overprint a data line, a marker, a bar or another
    text: empty when every label is clear (the figure must have been drawn)."""
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]  # an Agg canvas
    found = []
    for ax in fig.axes:
        bars = _boxes(ax, renderer)
        texts = [t for t in ax.texts if t.get_visible() and t.get_text()]
        boxes = [t.get_window_extent(renderer) for t in texts]
        for i, (text, box) in enumerate(zip(texts, boxes, strict=True)):
            others = bars + boxes[:i] + boxes[i + 1:]
            points = _line_points(ax, getattr(text, "nsrmp_own_line", None))
            if _hits(box, points, others):
                found.append(text.get_text())
    return found


def place_labels(fig: Figure) -> None:
    """Lay ``fig`` out, freeze the layout, and move every :func:`movable` text of its axes
    vertically to the nearest place where it overprints nothing."""
    agg = require("matplotlib.backends.backend_agg")
    if not isinstance(fig.canvas, agg.FigureCanvasAgg):
        agg.FigureCanvasAgg(fig)
    fig.canvas.draw()
    fig.set_layout_engine("none")
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]  # an Agg canvas
    for ax in fig.axes:
        texts = [t for t in ax.texts if t.get_gid() == GID and t.get_text()]
        if not texts:
            continue
        frame = ax.get_window_extent(renderer)
        placed = [t.get_window_extent(renderer) for t in ax.texts
                  if t.get_gid() != GID and t.get_text()]
        placed += _boxes(ax, renderer)
        for text in texts:
            points = _line_points(ax, getattr(text, "nsrmp_own_line", None))
            box = text.get_window_extent(renderer)
            dx, dy = _clear_shift(box, frame, points, placed)
            x, y = text.get_position()
            to_axes = ax.transAxes.inverted()
            x0, y0 = to_axes.transform((box.x0, box.y0))
            x1, y1 = to_axes.transform((box.x0 + dx, box.y0 + dy))
            if text.get_transform() is ax.transAxes:
                text.set_position((x + (x1 - x0), y + (y1 - y0)))
            else:  # x in data units (a mark at a divider): it moves up or down only
                text.set_position((x, y + (y1 - y0)))
            placed.append(box.translated(dx, dy))


def _clear_shift(box: Bbox, frame: Bbox, points: NDArray[np.float64], placed: list[Bbox]
                 ) -> tuple[float, float]:
    """The smallest shift (first up or down, then also leftwards, in steps of a tenth of
    the axes) that leaves ``box`` inside ``frame`` and clear of everything; (0, 0) when no
    place is clear."""
    for tenth in range(10):
        dx = -tenth * frame.width / 10
        if box.x0 + dx < frame.x0 + 1:
            break
        for step in range(0, int(frame.height), 2):
            for dy in ((step, -step) if step else (0,)):
                moved = box.translated(dx, dy)
                if moved.y0 < frame.y0 + 1 or moved.y1 > frame.y1 - 1:
                    continue
                if not _hits(moved, points, placed):
                    return dx, dy
    return 0.0, 0.0
