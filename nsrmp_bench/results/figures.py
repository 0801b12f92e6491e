"""The generalisation figures, drawn with matplotlib from a results summary.

Three figures, each written as PNG and SVG:

* ``iou_m_by_objects``: IoU-M with its 95% interval band against the number of objects,
  paper-v2/test (3–5, the training range) then objects-v2/test (6–15), one line per model;
* ``iou_m_by_steps``: the same against the number of steps, paper-v2/test (1–2) then
  steps-v2/test (3–7);
* ``iou_m_by_category``: bars with 95% intervals per category: paper-v2/test overall, by
  simple/relational and by phrasing, then language-v2/test (held-out templates and
  synonyms) and attributes-v2/test (held-out shape-colour pairs).

The first two are the paper's generalisation figures ("Performance in generalization
settings": large scenes, long plans) with the numbers it never published. Only the
``plot`` extra (matplotlib) is needed: no torch, no PyBullet. The files are the same
bytes for the same summary and matplotlib version (no dates, a fixed SVG hash salt);
the Agg canvas is used directly, so no pyplot state is touched.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nsrmp_bench._optional import require
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.results.summary import Estimate, Results

__all__ = ["CATEGORY_BARS", "FIGURES", "Curve", "category_bars", "curves", "draw_figures"]

PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#7f7f7f", "#9467bd", "#8c564b", "#e377c2",
           "#17becf", "#bcbd22", "#ff7f0e")
"""Colours in model order (the order the summary first names each model)."""


@dataclass(frozen=True)
class Axis:
    """One generalisation axis: the category and the split parts that span it."""

    name: str
    category: str
    label: str
    in_distribution: str
    held_out: str


FIGURES = (
    Axis("iou_m_by_objects", "objects", "number of objects", "paper-v2/test",
         "objects-v2/test"),
    Axis("iou_m_by_steps", "steps", "number of steps", "paper-v2/test", "steps-v2/test"),
)
"""The two line figures."""

CATEGORY_BARS = (
    ("paper-v2\noverall", "paper-v2/test", None, None),
    ("simple", "paper-v2/test", "relational", "False"),
    ("relational", "paper-v2/test", "relational", "True"),
    ("simple\nphrasing", "paper-v2/test", "phrasing", "simple"),
    ("complex\nphrasing", "paper-v2/test", "phrasing", "complex"),
    ("compound\nphrasing", "paper-v2/test", "phrasing", "compound"),
    ("held-out\nlanguage", "language-v2/test", None, None),
    ("held-out\nattribute pairs", "attributes-v2/test", None, None),
)
"""(label, split part, category or None for the part's overall figure, group)."""


@dataclass(frozen=True)
class Curve:
    """One model's points on an axis: x, and the IoU-M estimate at each x."""

    model: str
    xs: tuple[int, ...]
    estimates: tuple[Estimate, ...]


def curves(results: Results, axis: Axis) -> list[Curve]:
    """Each model's IoU-M by ``axis.category``, in-distribution part first."""
    out = []
    for model in results.models:
        points: dict[int, Estimate] = {}
        for split in (axis.in_distribution, axis.held_out):
            run = results.run(model, split)
            if run is None:
                continue
            for group, est in run.groups(axis.category, "iou_m"):
                if group.isdigit() and est.n > 0 and int(group) not in points:
                    points[int(group)] = est
        if points:
            xs = tuple(sorted(points))
            out.append(Curve(model, xs, tuple(points[x] for x in xs)))
    return out


def category_bars(results: Results) -> dict[str, list[Estimate]]:
    """Model -> its IoU-M estimate per entry of :data:`CATEGORY_BARS` (missing: NaN)."""
    table: dict[str, list[Estimate]] = {}
    for model in results.models:
        row = []
        for _label, split, category, group in CATEGORY_BARS:
            run = results.run(model, split)
            if run is None:
                row.append(Estimate.missing())
            elif category is None or group is None:
                row.append(run.metric("iou_m"))
            else:
                row.append(run.group(category, group, "iou_m"))
        if any(e.n > 0 for e in row):
            table[model] = row
    return table


def _figure(width: float, height: float) -> Any:
    mpl = require("matplotlib")
    figure_mod = require("matplotlib.figure")
    require("matplotlib.backends.backend_agg")
    mpl.rcParams["svg.hashsalt"] = "nsrmp-bench"
    return figure_mod.Figure(figsize=(width, height), dpi=100, layout="constrained")


def _save(fig: Any, out: Path, name: str) -> list[Path]:
    paths = [out / f"{name}.png", out / f"{name}.svg"]
    fig.savefig(paths[0], dpi=120, metadata={"Software": None})
    fig.savefig(paths[1], metadata={"Date": None, "Creator": None})
    return paths


def _colours(results: Results) -> dict[str, str]:
    return {m: PALETTE[i % len(PALETTE)] for i, m in enumerate(results.models)}


def _draw_axis(results: Results, axis: Axis, out: Path) -> list[Path]:
    found = curves(results, axis)
    if not found:
        return []
    colours = _colours(results)
    fig = _figure(6.4, 3.8)
    ax = fig.add_subplot()
    for curve in found:
        values = [e.value for e in curve.estimates]
        low = [e.low if math.isfinite(e.low) else e.value for e in curve.estimates]
        high = [e.high if math.isfinite(e.high) else e.value for e in curve.estimates]
        colour = colours[curve.model]
        ax.fill_between(curve.xs, low, high, color=colour, alpha=0.18, linewidth=0)
        ax.plot(curve.xs, values, marker="o", markersize=4, color=colour, label=curve.model)
    first = results.on(axis.in_distribution)
    in_range = sorted({int(g) for r in first for g, e in r.groups(axis.category, "iou_m")
                       if g.isdigit() and e.n > 0})
    if in_range:
        edge = in_range[-1] + 0.5
        ax.axvline(edge, color="#444444", linestyle="--", linewidth=0.8)
        ax.text(edge - 0.1, 1.02, axis.in_distribution.split("/")[0] + " (train range)",
                ha="right", va="bottom", fontsize=8, transform=ax.get_xaxis_transform())
        ax.text(edge + 0.1, 1.02, axis.held_out.split("/")[0] + " (held out)",
                ha="left", va="bottom", fontsize=8, transform=ax.get_xaxis_transform())
    xs = sorted({x for c in found for x in c.xs})
    ax.set_xticks(xs)
    ax.set_xlim(xs[0] - 0.5, xs[-1] + 0.5)
    ax.set_ylim(0.0, 1.05)
    ax.set_xlabel(axis.label)
    ax.set_ylabel("IoU-M (moved objects)")
    ax.grid(True, axis="y", linewidth=0.4, alpha=0.6)
    ax.legend(fontsize=8, loc="upper right", framealpha=0.9)
    ax.set_title(f"IoU-M by {axis.label}, 95% bootstrap intervals", fontsize=10, pad=16)
    return _save(fig, out, axis.name)


def _draw_categories(results: Results, out: Path) -> list[Path]:
    table = category_bars(results)
    if not table:
        return []
    colours = _colours(results)
    fig = _figure(7.6, 3.8)
    ax = fig.add_subplot()
    width = 0.8 / len(table)
    for i, (model, row) in enumerate(table.items()):
        xs = [k - 0.4 + width * (i + 0.5) for k in range(len(CATEGORY_BARS))]
        values = [e.value if e.n > 0 else math.nan for e in row]
        errors = [[max(0.0, e.value - e.low) if math.isfinite(e.low) else 0.0 for e in row],
                  [max(0.0, e.high - e.value) if math.isfinite(e.high) else 0.0 for e in row]]
        ax.bar(xs, values, width=width * 0.92, color=colours[model], label=model,
               yerr=errors, error_kw={"elinewidth": 0.8, "capsize": 2})
    ax.set_xticks(range(len(CATEGORY_BARS)), [label for label, *_ in CATEGORY_BARS],
                  fontsize=8)
    ax.axvline(5.5, color="#444444", linestyle="--", linewidth=0.8)
    ax.set_ylim(0.0, 1.05)
    ax.set_ylabel("IoU-M (moved objects)")
    ax.grid(True, axis="y", linewidth=0.4, alpha=0.6)
    fig.legend(fontsize=8, loc="outside lower center", ncol=len(table), frameon=False)
    ax.set_title("IoU-M by category (paper-v2/test | held-out splits), 95% intervals",
                 fontsize=10)
    return _save(fig, out, "iou_m_by_category")


def draw_figures(results: Results, out: str | os.PathLike[str],
                 names: Sequence[str] | None = None, *, none_ok: bool = False) -> list[Path]:
    """Draw every figure the results have data for into ``out``; returns the files.

    ``names`` picks figures by name (default: all). A results summary with no run on
    paper-v2, objects-v2, steps-v2, language-v2 or attributes-v2 has nothing to draw: an
    error, unless ``none_ok``.
    """
    known = [a.name for a in FIGURES] + ["iou_m_by_category"]
    wanted = list(known if names is None else names)
    unknown = [n for n in wanted if n not in known]
    if unknown:
        msg = f"unknown figure(s) {unknown}; the figures are {known}"
        raise InvalidArgument(msg)
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for axis in FIGURES:
        if axis.name in wanted:
            written += _draw_axis(results, axis, folder)
    if "iou_m_by_category" in wanted:
        written += _draw_categories(results, folder)
    if not written and not none_ok:
        msg = ("the results hold no run on paper-v2/test, objects-v2/test, steps-v2/test, "
               "language-v2/test or attributes-v2/test, so there is nothing to plot; "
               f"evaluate on those parts (runs here: {results.splits})")
        raise InvalidArgument(msg)
    return written
