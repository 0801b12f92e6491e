"""Paired comparison of two submissions on the same instances.

Both files are scored against the same gold table; for every metric, each instance's
difference A - B is formed (a missing prediction scores 0 on its side, as in scoring). The
mean difference gets a paired percentile bootstrap interval (instances resampled jointly)
and a two-sided paired sign-flip permutation test.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, SupportsFloat

import numpy as np
import pandas as pd

from nsrmp_bench.scoring.bootstrap import (
    bootstrap_intervals,
    resampling_method,
    sign_flip_pvalues,
)
from nsrmp_bench.scoring.gold import load_gold
from nsrmp_bench.scoring.metrics import METRICS_V2
from nsrmp_bench.scoring.result import json_ready
from nsrmp_bench.scoring.scorer import (
    DEFAULT_N_BOOT,
    DEFAULT_SEED,
    Data,
    Predictions,
    metric_columns,
    prepare,
    read_predictions,
)
from nsrmp_bench.scoring.version import SCORER_ID, check_scorer
from nsrmp_bench.storage.atomic import atomic_write_text
from nsrmp_bench.storage.split_root import part_of_split

if TYPE_CHECKING:
    import rich.console

__all__ = ["DEFAULT_N_PERM", "Comparison", "compare"]

DEFAULT_N_PERM = 10000
"""Random sign flips of the paired test."""


@dataclass(frozen=True, eq=False)
class Comparison:
    """Paired differences A - B: ``table`` (index: metric) has ``label, a, b, diff, ci_low,
    ci_high, p_value, n``; ``per_instance`` the two per-instance value frames side by side."""

    scorer: str
    split: str | None
    a: str
    b: str
    table: pd.DataFrame
    per_instance: pd.DataFrame
    settings: dict[str, Any] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    def __repr__(self) -> str:  # the frames would print hundreds of lines; see render()
        diff = float(self.table["diff"].to_dict().get("iou_m", float("nan")))
        return (f"Comparison(split={self.split!r}, a={self.a!r}, b={self.b!r}, "
                f"iou_m diff={diff:.4f}; .render() prints every difference, .table holds "
                "them)")

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (NaN as null)."""
        out: dict[str, Any] = json_ready({
            "scorer": self.scorer,
            "split": self.split,
            "a": self.a,
            "b": self.b,
            "settings": self.settings,
            "differences": self.table.reset_index().to_dict(orient="records"),
            "warnings": list(self.warnings),
        })
        return out

    def write_json(self, path: str | Path) -> Path:
        """Write :meth:`to_dict` as strict JSON."""
        return atomic_write_text(
            path, json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n")

    def render(self, console: rich.console.Console | None = None) -> None:
        """Print the differences as a rich table."""
        from rich.console import Console
        from rich.table import Table

        con = console if console is not None else Console()
        level = self.settings.get("level", 0.95)
        t = Table(
            title=f"{self.scorer} · split {self.split or '?'} · A = {self.a} · B = {self.b}",
            title_justify="left",
        )
        for col, justify in (("metric", "left"), ("A", "right"), ("B", "right"),
                             ("A - B", "right"), (f"{level:.0%} CI", "right"),
                             ("p (sign flip)", "right"), ("n", "right")):
            t.add_column(col, justify=justify)  # type: ignore[arg-type]

        def fmt(v: SupportsFloat | None, spec: str = ".3f") -> str:
            return "—" if v is None or not math.isfinite(float(v)) else format(float(v), spec)

        for _, row in self.table.iterrows():
            ci = (
                f"[{fmt(row['ci_low'], '+.3f')}, {fmt(row['ci_high'], '+.3f')}]"
                if math.isfinite(float(row["ci_low"]))
                else ""
            )
            t.add_row(str(row["label"]), fmt(row["a"]), fmt(row["b"]), fmt(row["diff"], "+.3f"),
                      ci, fmt(row["p_value"], ".4f"), str(int(row["n"])))
        con.print(t)
        for w in self.warnings:
            con.print(f"[yellow]warning:[/yellow] {w}")


def compare(
    a: Predictions,
    b: Predictions,
    data: Data,
    *,
    seed: int = DEFAULT_SEED,
    n_boot: int = DEFAULT_N_BOOT,
    n_perm: int = DEFAULT_N_PERM,
    level: float = 0.95,
    unknown_ids: str = "error",
    split: str | None = None,
    scorer: str = SCORER_ID,
) -> Comparison:
    """Paired differences of every metric of ``scorer`` between submissions ``a`` and ``b``
    on ``data``."""
    check_scorer(scorer)
    read_a, read_b = read_predictions(a), read_predictions(b)
    gold = load_gold(data, split=split, part=part_of_split(read_a[0].header.split))
    table_a, frame_a, _ = prepare(read_a, gold, unknown_ids=unknown_ids, scorer=scorer)
    table_b, frame_b, _ = prepare(read_b, gold, unknown_ids=unknown_ids, scorer=scorer)
    cols = [c for c in metric_columns(gold, frame_a) if c in frame_b.columns]
    va = frame_a[cols].to_numpy(dtype=np.float64)
    vb = frame_b[cols].to_numpy(dtype=np.float64)
    diff = va - vb  # NaN where either side is undefined
    rng = np.random.default_rng(seed)
    intervals, _ = bootstrap_intervals(diff, rng, n_boot=n_boot, level=level)
    p_values = sign_flip_pvalues(diff, rng, n_perm=n_perm)
    both = ~np.isnan(diff)
    labels = {m.name: m.label for m in METRICS_V2}
    rows = []
    for i, c in enumerate(cols):
        sel = both[:, i]
        rows.append({
            "metric": c,
            "label": labels.get(c, f"IoU-M after step {c.rsplit('_', 1)[-1]}"),
            "a": float(va[sel, i].mean()) if sel.any() else math.nan,
            "b": float(vb[sel, i].mean()) if sel.any() else math.nan,
            "diff": intervals.mean[i],
            "ci_low": intervals.low[i],
            "ci_high": intervals.high[i],
            "p_value": p_values[i],
            "n": int(intervals.n[i]),
        })
    per_instance = pd.concat({"a": frame_a[cols], "b": frame_b[cols]}, axis=1)
    warnings = tuple(f"A: {w}" for w in table_a.warnings) + tuple(
        f"B: {w}" for w in table_b.warnings
    )
    return Comparison(
        scorer=scorer,
        split=gold.split or table_a.header.split,
        a=table_a.header.model or table_a.source,
        b=table_b.header.model or table_b.source,
        table=pd.DataFrame(rows).set_index("metric"),
        per_instance=per_instance,
        settings={"seed": seed, "n_boot": n_boot, "n_perm": n_perm, "level": level,
                  "interval": "paired percentile bootstrap over instances",
                  "resampling": resampling_method(gold.n_instances),
                  "test": "two-sided paired sign-flip permutation test"},
        warnings=warnings,
    )
