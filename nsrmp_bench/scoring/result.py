"""The outcome of scoring: tables of figures with intervals, counts, warnings, and views.

A :class:`ScoreResult` holds pandas DataFrames (summary, per step, per category, per
instance), writes itself as JSON, and prints itself as rich tables.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import pandas as pd

from nsrmp_bench.errors import InvalidArgument, UnknownId
from nsrmp_bench.plurals import counted
from nsrmp_bench.storage.atomic import atomic_write_text

if TYPE_CHECKING:
    import rich.console

__all__ = ["BREAKDOWNS", "BREAKDOWN_SHOWN", "PAPER_TABLE_EXTRA", "SHORT_BREAKDOWN", "ScoreResult",
           "json_ready"]

BREAKDOWN_SHOWN = ("iou_m", "iou", "success", "success_strict", "kept_still", "program_exact")
"""The metrics the printed breakdown shows where the scorer reports them (the JSON and
DataFrames hold all of them; ``scorer-v1`` has no strict success or kept still)."""

PAPER_TABLE_EXTRA = {"success_strict": "success strict", "kept_still": "kept still"}
"""``scorer-v2``'s columns beside the paper's IoU and IoU-M in :meth:`ScoreResult.paper_table`."""

SHORT_BREAKDOWN = ("steps", "objects", "relational", "phrasing")
"""The categories the printed breakdown shows by default (``breakdown="short"``)."""

BREAKDOWNS = ("short", "all", "none")
"""How much of the breakdown :meth:`ScoreResult.render` prints: the categories of
:data:`SHORT_BREAKDOWN`, every category (templates too), or none."""


def json_ready(value: object) -> Any:
    """``value`` with NaN and infinities as None and numpy scalars as Python ones."""
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_ready(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, str):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _num(value: Any) -> float:
    return float(value)


def _fmt(value: float, digits: int = 3) -> str:
    return "—" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def _cell(row: pd.Series, kind: str, metric: str) -> float:
    """One value of a pivoted breakdown row; NaN where the pivot dropped an all-NaN column
    (intervals when none were computed)."""
    key = (kind, metric)
    return _num(row[key]) if key in row.index else math.nan


def _ci(low: float, high: float) -> str:
    if not (math.isfinite(low) and math.isfinite(high)):
        return ""
    return f"[{low:.3f}, {high:.3f}]"


@dataclass(frozen=True, eq=False)
class ScoreResult:
    """Every figure of one scored predictions file.

    ``summary`` (index: metric) has ``label, value, ci_low, ci_high, n, paper,
    description``; ``per_step`` (index: step) the per-step IoU-M; ``per_category`` is long
    (``category, group, metric, value, ci_low, ci_high, n``); ``per_instance`` (index: id)
    holds each instance's values, ``present``, and its categories.
    """

    scorer: str
    split: str | None
    source: str
    model: str | None
    summary: pd.DataFrame
    per_step: pd.DataFrame
    per_category: pd.DataFrame
    per_instance: pd.DataFrame
    counts: dict[str, int]
    warnings: tuple[str, ...]
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def headline(self) -> float:
        """IoU-M, the headline figure."""
        return self.value("iou_m")

    def __repr__(self) -> str:  # the frames would print hundreds of lines; see render()
        n = self.counts.get("instances", len(self.per_instance))
        return (f"ScoreResult(split={self.split!r}, model={self.model!r}, "
                f"iou_m={self.headline:.4f}, n={n}, warnings={len(self.warnings)}; "
                ".render() prints every figure, .summary holds them)")

    def value(self, metric: str) -> float:
        """One metric's value (NaN when not reported, e.g. success_3d without positions)."""
        if metric not in self.summary.index:
            msg = f"no metric {metric!r}; reported: {list(self.summary.index)}"
            raise UnknownId(msg)
        return _num(self.summary.at[metric, "value"])

    def interval(self, metric: str) -> tuple[float, float]:
        """A metric's bootstrap interval (low, high)."""
        self.value(metric)
        return _num(self.summary.at[metric, "ci_low"]), _num(self.summary.at[metric, "ci_high"])

    def breakdown(self, metric: str = "iou_m") -> pd.DataFrame:
        """One metric by category: index (category, group); value, ci_low, ci_high, n."""
        self.value(metric)
        rows = self.per_category[self.per_category["metric"] == metric]
        return rows.set_index(["category", "group"])[["value", "ci_low", "ci_high", "n"]]

    def paper_table(self) -> pd.DataFrame:
        """The paper's Table I layout: IoU and IoU-M overall, by steps and simple/complex
        (under ``scorer-v2`` with strict success and kept still beside them)."""
        cat = self.per_category
        extra = {m: label for m, label in PAPER_TABLE_EXTRA.items() if m in self.summary.index}
        rows: dict[str, dict[str, float]] = {
            "overall": {"IoU": self.value("iou"), "IoU-M": self.value("iou_m"),
                        **{label: self.value(m) for m, label in extra.items()},
                        "n": _num(self.summary.at["iou", "n"])},
        }
        for name, category, group in (
            ("single-step", "steps", "1"),
            ("double-step", "steps", "2"),
            ("simple", "relational", "False"),
            ("complex", "relational", "True"),
        ):
            sel = cat[(cat["category"] == category) & (cat["group"] == group)]
            if len(sel):
                by = sel.set_index("metric")
                rows[name] = {"IoU": _num(by.at["iou", "value"]),
                              "IoU-M": _num(by.at["iou_m", "value"]),
                              **{label: _num(by.at[m, "value"]) for m, label in extra.items()},
                              "n": _num(by.at["iou", "n"])}
        return pd.DataFrame.from_dict(rows, orient="index")

    # -- output ---------------------------------------------------------------------------
    def to_dict(self, *, per_instance: bool = False) -> dict[str, Any]:
        """JSON-able form (NaN as null); per-instance rows only when asked."""
        out: dict[str, Any] = {
            "scorer": self.scorer,
            "split": self.split,
            "submission": self.source,
            "model": self.model,
            "settings": self.settings,
            "summary": {
                str(m): {k: row[k] for k in ("label", "value", "ci_low", "ci_high", "n",
                                             "paper", "description")}
                for m, row in self.summary.iterrows()
            },
            "per_step": self.per_step.reset_index().to_dict(orient="records"),
            "per_category": self.per_category.to_dict(orient="records"),
            "counts": self.counts,
            "warnings": list(self.warnings),
        }
        if per_instance:
            out["per_instance"] = self.per_instance.reset_index().to_dict(orient="records")
        result: dict[str, Any] = json_ready(out)
        return result

    def write_json(self, path: str | Path, *, per_instance: bool = False) -> Path:
        """Write :meth:`to_dict` as strict JSON."""
        return atomic_write_text(path, json.dumps(
            self.to_dict(per_instance=per_instance), indent=2, allow_nan=False) + "\n")

    def render(self, console: rich.console.Console | None = None, *,
               breakdown: str = "short") -> None:
        """Print the figures as rich tables: the headline table, IoU-M after each step, and
        the breakdown by the categories ``breakdown`` names (one of :data:`BREAKDOWNS`)."""
        from rich.console import Console
        from rich.table import Table

        if breakdown not in BREAKDOWNS:
            msg = f"breakdown={breakdown!r}; expected one of {list(BREAKDOWNS)}"
            raise InvalidArgument(msg)

        con = console if console is not None else Console()
        n = self.counts.get("instances", 0)
        missing = self.counts.get("missing", 0)
        level = self.settings.get("level", 0.95)
        title = (
            f"{self.scorer} · split {self.split or '?'} · {counted(n, 'instance')}"
            f" ({missing} missing) · {self.model or Path(self.source).name}"
        )
        t = Table(title=title, title_justify="left")
        t.add_column("metric")
        t.add_column("value", justify="right")
        t.add_column(f"{level:.0%} CI", justify="right")
        t.add_column("n", justify="right")
        t.add_column("paper", style="dim")
        for _, row in self.summary.iterrows():
            value = row["value"]
            shown = _fmt(value) if row["n"] else "not submitted"
            t.add_row(str(row["label"]), shown, _ci(row["ci_low"], row["ci_high"]),
                      str(int(row["n"])), str(row["paper"]))
        con.print(t)
        if len(self.per_step):
            s = Table(title="IoU-M after each step", title_justify="left")
            s.add_column("step", justify="right")
            s.add_column("IoU-M", justify="right")
            s.add_column(f"{level:.0%} CI", justify="right")
            s.add_column("n", justify="right")
            for step, row in self.per_step.iterrows():
                s.add_row(str(step), _fmt(row["value"]), _ci(row["ci_low"], row["ci_high"]),
                          str(int(row["n"])))
            con.print(s)
        categories = self.per_category
        hidden: list[str] = []
        if breakdown != "all" and len(categories):
            wanted: tuple[str, ...] = SHORT_BREAKDOWN if breakdown == "short" else ()
            hidden = [str(c) for c in categories["category"].unique() if c not in wanted]
            categories = categories[categories["category"].isin(wanted)]
        if len(categories):
            b = Table(title="Breakdown", title_justify="left")
            b.add_column("category", no_wrap=True, min_width=10)
            b.add_column("group", no_wrap=True, max_width=10, overflow="ellipsis")
            b.add_column("n", justify="right", min_width=3)
            b.add_column("IoU-M", justify="right", min_width=5)
            b.add_column(f"{level:.0%} CI", justify="right", no_wrap=True)
            columns = [m for m in BREAKDOWN_SHOWN[1:] if m in self.summary.index]
            for m in columns:
                b.add_column(str(self.summary.at[m, "label"]), justify="right", min_width=5)
            wide = categories.pivot_table(
                index=["category", "group"], columns="metric",
                values=["value", "ci_low", "ci_high", "n"], aggfunc="first", sort=False,
            )
            previous = None
            for key, row in wide.iterrows():
                category, group = cast(tuple[str, str], key)
                shown_cat = "" if category == previous else str(category)
                previous = category
                b.add_row(
                    shown_cat, str(group), str(int(_cell(row, "n", "iou"))),
                    _fmt(_cell(row, "value", "iou_m")),
                    _ci(_cell(row, "ci_low", "iou_m"), _cell(row, "ci_high", "iou_m")),
                    *(_fmt(_cell(row, "value", m)) for m in columns),
                )
            con.print(b)
        if hidden:
            con.print(f"[dim]breakdown by {', '.join(hidden)}: --breakdown all "
                      "(every figure: --json)[/dim]")
        nonzero = {k: v for k, v in self.counts.items() if v}
        con.print("counts: " + ", ".join(f"{k}={v}" for k, v in nonzero.items()))
        for w in self.warnings:
            con.print(f"[yellow]warning:[/yellow] {w}")
