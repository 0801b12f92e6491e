"""The generalisation figures, drawn with matplotlib from a results summary.

Three figures on the official parts, each written as PNG and SVG:

* ``iou_m_by_objects``: IoU-M with its 95% interval band against the number of objects,
  paper-v2/test (3–5, the training range) then objects-v2/test (6–15);
* ``iou_m_by_steps``: the same against the number of steps, paper-v2/test (1–2) then
  steps-v2/test (3–7);
* ``iou_m_by_category``: bars with 95% intervals per category: paper-v2/test overall, by
  simple/relational and by phrasing, then language-v2/test (held-out templates and
  synonyms) and attributes-v2/test (held-out shape-colour pairs).

Any other evaluated part (smoke-v2/test, a validation part) gets the same three figures
on its own, named ``<figure>--<split>-<part>`` (:func:`figure_names`): the generalisation
axes of what it holds.

How they read: every model id has one colour and marker (:mod:`.colours`), the same in
every figure and on the site. The reference rows (oracle, noop, random: the ``baseline``
kind) are grey labelled lines, not coloured series, and the value axis is fitted to the
models, so an oracle at 1.0 does not squeeze them; a reference off the scale is named with
its value at the edge; every label inside the axes is moved clear of the data lines,
markers and bars (:mod:`.label_place`). The legend sits below the axes, outside them, in
as many rows as it needs. Where one axis would hold more than :data:`MAX_CURVES` models,
the figure becomes small multiples, one panel per protocol (gold boxes, detected boxes,
dense; :mod:`.protocols`) with a shared value axis.

Only the ``plot`` extra (matplotlib) is needed: no torch, no PyBullet. The files are the
same bytes for the same summary and matplotlib version (no dates, a fixed SVG hash salt);
the Agg canvas is used directly, so no pyplot state is touched.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nsrmp_bench._optional import require
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.results.colours import Style, model_styles, reference_style
from nsrmp_bench.results.label_place import movable, place_labels
from nsrmp_bench.results.protocols import PROTOCOLS, is_reference, protocol_of
from nsrmp_bench.results.summary import Estimate, Results

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "CATEGORY_BARS",
    "FIGURES",
    "MAX_CURVES",
    "Curve",
    "caption",
    "category_bars",
    "curves",
    "draw_figures",
    "figure_names",
    "render",
]

MAX_CURVES = 6
"""More models than this on one axis and the figure is split by protocol."""


@dataclass(frozen=True)
class Axis:
    """One generalisation axis: the category and the split parts that span it."""

    name: str
    category: str
    label: str
    in_distribution: str
    held_out: str | None


FIGURES = (
    Axis("iou_m_by_objects", "objects", "number of objects", "paper-v2/test",
         "objects-v2/test"),
    Axis("iou_m_by_steps", "steps", "number of steps", "paper-v2/test", "steps-v2/test"),
)
"""The two line figures on the official parts."""

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

OFFICIAL = frozenset({a.in_distribution for a in FIGURES}
                     | {a.held_out for a in FIGURES if a.held_out}
                     | {part for _, part, _, _ in CATEGORY_BARS})
"""The parts the official figures span; any other part gets figures of its own."""

BARS = "iou_m_by_category"
_CAPTIONS = {
    "iou_m_by_objects": "IoU-M against the number of objects: paper-v2/test (3–5, the "
                        "training range) then objects-v2/test (6–15); bands are 95% "
                        "bootstrap intervals, grey lines the reference rows.",
    "iou_m_by_steps": "IoU-M against the number of steps: paper-v2/test (1–2) then "
                      "steps-v2/test (3–7); bands are 95% bootstrap intervals, grey "
                      "lines the reference rows.",
    BARS: "IoU-M per category of paper-v2/test, then the held-out language "
          "(language-v2/test) and attribute pairs (attributes-v2/test); bars show 95% "
          "intervals, grey lines the reference rows.",
}


def _stem(split: str) -> str:
    return split.replace("/", "-")


def _own_parts(results: Results) -> list[str]:
    return [s for s in results.splits if s not in OFFICIAL]


def _part_axes(split: str) -> list[Axis]:
    return [Axis(f"{a.name}--{_stem(split)}", a.category, a.label, split, None)
            for a in FIGURES]


def _part_bars(split: str) -> tuple[tuple[str, str, str | None, str | None], ...]:
    return ((f"{split}\noverall", split, None, None),
            *((label, split, category, group)
              for label, part, category, group in CATEGORY_BARS
              if part == "paper-v2/test" and category is not None))


def figure_names(results: Results | None = None) -> list[str]:
    """The names of the figures: the official three, then three per other part of
    ``results`` (default: the official ones only)."""
    names = [a.name for a in FIGURES] + [BARS]
    for split in _own_parts(results) if results is not None else []:
        names += [a.name for a in _part_axes(split)] + [f"{BARS}--{_stem(split)}"]
    return names


def caption(name: str) -> str:
    """What a figure shows, for an ``alt`` text and a caption."""
    if name in _CAPTIONS:
        return _CAPTIONS[name]
    base, _, stem = name.partition("--")
    what = {"iou_m_by_objects": "the number of objects", "iou_m_by_steps":
            "the number of steps", BARS: "category"}.get(base)
    if what is None or not stem:
        msg = f"unknown figure {name!r}; the figures are named like {figure_names()}"
        raise InvalidArgument(msg)
    return (f"IoU-M by {what} on {stem} alone, with 95% intervals; grey lines are the "
            "reference rows.")


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
            run = results.run(model, split) if split is not None else None
            if run is None:
                continue
            for group, est in run.groups(axis.category, "iou_m"):
                if group.isdigit() and est.n > 0 and int(group) not in points:
                    points[int(group)] = est
        if points:
            xs = tuple(sorted(points))
            out.append(Curve(model, xs, tuple(points[x] for x in xs)))
    return out


def category_bars(results: Results, bars: Sequence[tuple[str, str, str | None, str | None]]
                  = CATEGORY_BARS) -> dict[str, list[Estimate]]:
    """Model -> its IoU-M estimate per entry of ``bars`` (missing: NaN)."""
    table: dict[str, list[Estimate]] = {}
    for model in results.models:
        row = []
        for _label, split, category, group in bars:
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


class _Look:
    """Styles, references and protocols of every model of one summary."""

    def __init__(self, results: Results) -> None:
        self.references = {r.model for r in results.runs if is_reference(r.kind)}
        self.styles: dict[str, Style] = model_styles(
            m for m in results.models if m not in self.references)
        self.protocols = {}
        for model in results.models:
            run = next(r for r in results.runs if r.model == model)
            self.protocols[model] = protocol_of(model, run.counts).name

    def panels(self, models: Sequence[str]) -> list[tuple[str, list[str]]]:
        """(title, models) per panel: one panel, or one per protocol present."""
        if len(models) <= MAX_CURVES:
            return [("", list(models))]
        return [(p, [m for m in models if self.protocols[m] == p]) for p in PROTOCOLS
                if any(self.protocols[m] == p for m in models)]


def _figure(width: float, height: float) -> Any:
    mpl = require("matplotlib")
    figure_mod = require("matplotlib.figure")
    require("matplotlib.backends.backend_agg")
    mpl.rcParams["svg.hashsalt"] = "nsrmp-bench"
    return figure_mod.Figure(figsize=(width, height), dpi=100, layout="constrained")


def _save(fig: Figure, out: Path, name: str) -> list[Path]:
    paths = [out / f"{name}.png", out / f"{name}.svg"]
    fig.savefig(paths[0], dpi=120, metadata={"Software": None})
    fig.savefig(paths[1], metadata={"Date": None, "Creator": None})
    return paths


def _finite(values: Sequence[float]) -> list[float]:
    return [v for v in values if math.isfinite(v)]


def _value_range(estimates: Sequence[Estimate], *, from_zero: bool,
                 headroom: float = 0.06) -> tuple[float, float]:
    lows = _finite([e.low if math.isfinite(e.low) else e.value for e in estimates])
    highs = _finite([e.high if math.isfinite(e.high) else e.value for e in estimates])
    if not lows:
        return 0.0, 1.05
    top = min(1.05, max(highs) + headroom)
    bottom = 0.0 if from_zero else max(0.0, min(lows) - 0.06)
    return bottom, max(top, bottom + 0.1)


def _legend(fig: Figure, handles: list[Artist], labels: list[str], width: float) -> None:
    longest = max(len(label) for label in labels)
    columns = max(1, min(len(labels), int(width * 72 / (longest * 5.2 + 34))))
    fig.legend(handles, labels, loc="outside lower center", ncol=columns, fontsize=8,
               frameon=False, columnspacing=1.2, handlelength=2.2)


def _off_scale(ax: Axes, model: str, value: float, low: float, high: float,
               slot: int) -> None:
    above = value > high
    movable(ax.text(0.99, 0.91 - 0.07 * slot if above else 0.02 + 0.07 * slot,
                    f"{model} {value:.2f} ({'above' if above else 'below'} the scale)",
                    transform=ax.transAxes, ha="right", va="top" if above else "bottom",
                    fontsize=7, color=reference_style(model).colour))


def _draw_axis(results: Results, axis: Axis, look: _Look) -> Any:
    found = curves(results, axis)
    if not found:
        return None
    refs = [c for c in found if c.model in look.references]
    models = [c for c in found if c.model not in look.references]
    panels = look.panels([c.model for c in models])
    by_model = {c.model: c for c in found}
    low, high = _value_range([e for c in (models or refs) for e in c.estimates],
                             from_zero=False)
    width = max(6.4, 3.4 * len(panels) + 0.8)
    fig = _figure(width, 4.4)
    axes = fig.subplots(1, len(panels), sharey=True, squeeze=False)[0]
    handles: dict[str, Any] = {}
    xs = sorted({x for c in found for x in c.xs})
    train = sorted({x for r in results.on(axis.in_distribution)
                    for x in (int(g) for g, e in r.groups(axis.category, "iou_m")
                              if g.isdigit() and e.n > 0)})
    for ax, (title, members) in zip(axes, panels, strict=True):
        for model in members:
            curve, style = by_model[model], look.styles[model]
            bands = [(e.low if math.isfinite(e.low) else e.value,
                      e.high if math.isfinite(e.high) else e.value) for e in curve.estimates]
            ax.fill_between(curve.xs, [b[0] for b in bands], [b[1] for b in bands],
                            color=style.colour, alpha=0.15, linewidth=0)
            (handles[model],) = ax.plot(curve.xs, [e.value for e in curve.estimates],
                                        marker=style.marker, markersize=4.5,
                                        color=style.colour, linewidth=1.6)
        slot = 0
        labels: list[tuple[float, str, str, Any]] = []  # (height in the axes, text, colour, line)
        for ref in refs:
            style = reference_style(ref.model)
            values = [e.value for e in ref.estimates]
            (handles[ref.model],) = ax.plot(ref.xs, values, color=style.colour,
                                            linestyle=style.linestyle, linewidth=1.1)
            if low <= values[-1] <= high:
                labels.append(((values[-1] - low) / (high - low), ref.model, style.colour,
                               handles[ref.model]))
            else:
                _off_scale(ax, ref.model, sum(values) / len(values), low, high, slot)
                slot += 1
        floor = -1.0
        for height, text, colour, line in sorted(labels, key=lambda x: x[:3]):
            floor = max(height + 0.01, floor + 0.05)  # stacked, never on top of each other
            movable(ax.text(0.99, floor, text, transform=ax.transAxes, ha="right",
                            va="bottom", fontsize=7, color=colour), own=line)
        if axis.held_out is not None and train and train[-1] < xs[-1]:
            edge = train[-1] + 0.5
            ax.axvline(edge, color="#444444", linestyle="--", linewidth=0.8)
            movable(ax.text(edge - 0.1, 0.98, "train range", ha="right", va="top",
                            fontsize=7, transform=ax.get_xaxis_transform()))
            movable(ax.text(edge + 0.1, 0.98, "held out", ha="left", va="top", fontsize=7,
                            transform=ax.get_xaxis_transform()))
        ax.set_xticks(xs)
        ax.set_xlim(xs[0] - 0.5, xs[-1] + 0.5)
        ax.set_ylim(low, high)
        ax.set_xlabel(axis.label)
        ax.grid(True, axis="y", linewidth=0.4, alpha=0.6)
        if title:
            ax.set_title(title, fontsize=9)
    axes[0].set_ylabel("IoU-M (moved objects)")
    parts = axis.in_distribution + (f" then {axis.held_out}" if axis.held_out else "")
    fig.suptitle(f"IoU-M by {axis.label} ({parts}), 95% bootstrap intervals", fontsize=10)
    order = [c.model for c in models] + [c.model for c in refs]
    _legend(fig, [handles[m] for m in order],
            [m if m not in look.references else f"{m} (reference)" for m in order], width)
    place_labels(fig)
    return fig


def _draw_categories(results: Results, title: str,
                     bars: Sequence[tuple[str, str, str | None, str | None]],
                     divider: float | None, look: _Look) -> Any:
    table = category_bars(results, bars)
    if not table:
        return None
    refs = [m for m in table if m in look.references]
    models = [m for m in table if m not in look.references]
    panels = look.panels(models) if models else [("", [])]
    estimates = [e for m in (models or refs) for e in table[m]]
    low, high = _value_range(estimates, from_zero=True, headroom=0.1)  # room for a label
    width = 8.4
    fig = _figure(width, 1.2 + 2.5 * len(panels))
    axes = fig.subplots(len(panels), 1, sharex=True, sharey=True, squeeze=False)[:, 0]
    handles: dict[str, Any] = {}
    for ax, (panel, members) in zip(axes, panels, strict=True):
        step = 0.8 / max(1, len(members))
        for i, model in enumerate(members):
            row = table[model]
            xs = [k - 0.4 + step * (i + 0.5) for k in range(len(bars))]
            values = [e.value if e.n > 0 else math.nan for e in row]
            errors = [[max(0.0, e.value - e.low) if math.isfinite(e.low) else 0.0
                       for e in row],
                      [max(0.0, e.high - e.value) if math.isfinite(e.high) else 0.0
                       for e in row]]
            handles[model] = ax.bar(xs, values, width=step * 0.92,
                                    color=look.styles[model].colour, yerr=errors,
                                    error_kw={"elinewidth": 0.8, "capsize": 2})
        slot = 0
        for model in refs:
            style = reference_style(model)
            values = [e.value for e in table[model] if e.n > 0]
            for k, e in enumerate(table[model]):
                if e.n > 0 and low <= e.value <= high:
                    (handles[model],) = ax.plot([k - 0.45, k + 0.45], [e.value, e.value],
                                                color=style.colour, linewidth=1.3,
                                                linestyle=style.linestyle)
            if values and not all(low <= v <= high for v in values):
                _off_scale(ax, model, sum(values) / len(values), low, high, slot)
                slot += 1
                if model not in handles:
                    (handles[model],) = ax.plot([], [], color=style.colour,
                                                linestyle=style.linestyle)
        if divider is not None:
            ax.axvline(divider, color="#444444", linestyle="--", linewidth=0.8)
        ax.set_ylim(low, high)
        ax.set_ylabel("IoU-M")
        ax.grid(True, axis="y", linewidth=0.4, alpha=0.6)
        if panel:
            ax.set_title(panel, fontsize=9, loc="left")
    axes[-1].set_xticks(range(len(bars)), [label for label, *_ in bars], fontsize=8)
    fig.suptitle(title, fontsize=10)
    order = models + refs
    _legend(fig, [handles[m] for m in order if m in handles],
            [m if m not in look.references else f"{m} (reference)"
             for m in order if m in handles], width)
    place_labels(fig)
    return fig


def _draw(results: Results, name: str, look: _Look) -> Any:
    """The figure ``name`` (a matplotlib Figure), or None when there is nothing to draw."""
    axes = {a.name: a for a in FIGURES}
    axes.update({a.name: a for s in _own_parts(results) for a in _part_axes(s)})
    if name in axes:
        return _draw_axis(results, axes[name], look)
    if name == BARS:
        return _draw_categories(
            results, "IoU-M by category (paper-v2/test | held-out splits), 95% intervals",
            CATEGORY_BARS, 5.5, look)
    split = next(s for s in _own_parts(results) if name == f"{BARS}--{_stem(s)}")
    return _draw_categories(results, f"IoU-M by category ({split}), 95% intervals",
                            _part_bars(split), None, look)


def render(results: Results, name: str) -> Any:
    """The figure ``name`` of :func:`figure_names` as a matplotlib ``Figure`` (not saved)."""
    known = figure_names(results)
    if name not in known:
        msg = f"unknown figure {name!r}; the figures of these results are {known}"
        raise InvalidArgument(msg)
    fig = _draw(results, name, _Look(results))
    if fig is None:
        msg = (f"the results hold nothing for {name} (runs here: {results.splits}); "
               "evaluate the parts it draws")
        raise InvalidArgument(msg)
    return fig


def draw_figures(results: Results, out: str | os.PathLike[str],
                 names: Sequence[str] | None = None, *, none_ok: bool = False) -> list[Path]:
    """Draw every figure the results have data for into ``out``; returns the files.

    ``names`` picks figures by name (default: all of :func:`figure_names`). Results with
    no run at all have nothing to draw: an error, unless ``none_ok``.
    """
    known = figure_names(results)
    wanted = list(known if names is None else names)
    unknown = [n for n in wanted if n not in known]
    if unknown:
        msg = f"unknown figure(s) {unknown}; the figures of these results are {known}"
        raise InvalidArgument(msg)
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    look = _Look(results)
    written: list[Path] = []
    for name in wanted:
        fig = _draw(results, name, look)
        if fig is not None:
            written += _save(fig, folder, name)
    if not written and not none_ok:
        msg = ("the results hold no run with IoU-M by objects, steps or category, so there "
               f"is nothing to plot (runs here: {results.splits}); evaluate a part with "
               "`nsrmp-bench evaluate MODEL --data-root ROOT --out DIR`")
        raise InvalidArgument(msg)
    return written
