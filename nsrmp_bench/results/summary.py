"""``summary.json``: the scored runs that plots, reports and the web leaderboard read.

A *run* is one predictions file scored by the public scorer on one split part: its model,
its headline figures with 95% intervals, IoU-M after each step, and the breakdown by
category. ``nsrmp-bench evaluate`` writes a summary into its output folder and
``nsrmp-bench leaderboard`` writes one for the committed entries into the site folder; both
have the same format, so ``plot`` and ``report`` take either. Reading needs only the
standard library (no torch, PyBullet or matplotlib).

Only the figures in :data:`KEPT_METRICS` are kept, and the breakdown by template is left
out (it has one group per template; the per-split CSV of ``evaluate`` holds everything).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.results.robustness_table import Suite, suite_from_dict
from nsrmp_bench.scoring.result import ScoreResult
from nsrmp_bench.storage.atomic import atomic_write_text
from nsrmp_bench.storage.layout import check_schema_version

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "FORMAT",
    "KEPT_METRICS",
    "SCHEMA_VERSION",
    "SUMMARY_FILE",
    "Estimate",
    "Results",
    "Run",
]

SUMMARY_FILE = "summary.json"
FORMAT = "nsrmp-bench-results"
SCHEMA_VERSION = "1.0.0"
KEPT_METRICS = (
    "iou_m", "iou", "success", "program_exact", "action_all_steps", "subject_all_steps",
    "predicate_all_steps", "identification", "placement", "success_strict", "kept_still",
    "abstention",
)
"""The figures a summary keeps, per run and per category group (the last three where the
run was scored with ``scorer-v2``)."""
LEFT_OUT_CATEGORIES = frozenset({"template"})


@dataclass(frozen=True)
class Estimate:
    """A mean with its bootstrap interval and the number of instances behind it."""

    value: float
    low: float
    high: float
    n: int

    @classmethod
    def missing(cls) -> Estimate:
        """What a figure that was not reported reads as (NaN, n = 0)."""
        return cls(math.nan, math.nan, math.nan, 0)

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Estimate:
        """Parse ``{"value", "ci_low", "ci_high", "n"}`` (null is NaN)."""
        def num(key: str) -> float:
            v = data.get(key)
            return math.nan if v is None else float(v)

        return cls(num("value"), num("ci_low"), num("ci_high"), int(data.get("n") or 0))

    def to_json(self) -> dict[str, Any]:
        """Strict-JSON form (NaN as null)."""
        def clean(v: float) -> float | None:
            return v if math.isfinite(v) else None

        return {"value": clean(self.value), "ci_low": clean(self.low),
                "ci_high": clean(self.high), "n": self.n}


@dataclass(frozen=True)
class Run:
    """One predictions file scored on one split part."""

    model: str
    split: str
    predictions: str
    kind: str
    scorer: str
    summary: dict[str, Estimate]
    per_step: dict[int, Estimate]
    per_category: dict[tuple[str, str, str], Estimate]
    counts: dict[str, int] = field(default_factory=dict)

    @classmethod
    def from_score(cls, result: ScoreResult, *, model: str, kind: str,
                   predictions: str) -> Run:
        """The kept figures of a :class:`ScoreResult`."""
        if result.split is None:
            msg = (f"{result.source}: the scored data records no split id; score it with "
                   "split=... so the run can be placed on a board")
            raise InvalidArgument(msg)

        def est(row: pd.Series) -> Estimate:
            return Estimate.from_json({k: (None if _nan(row[k]) else row[k])
                                       for k in ("value", "ci_low", "ci_high", "n")})

        summary = {str(m): est(row) for m, row in result.summary.iterrows()
                   if m in KEPT_METRICS}
        per_step = {int(str(s)): est(row) for s, row in result.per_step.iterrows()}
        cat = result.per_category
        per_category = {
            (str(r["category"]), str(r["group"]), str(r["metric"])): est(r)
            for _, r in cat.iterrows()
            if r["metric"] in KEPT_METRICS and r["category"] not in LEFT_OUT_CATEGORIES
        }
        return cls(model=model, split=result.split, predictions=predictions, kind=kind,
                   scorer=result.scorer, summary=summary, per_step=per_step,
                   per_category=per_category, counts=dict(result.counts))

    def metric(self, name: str) -> Estimate:
        """A headline figure (``Estimate.missing()`` when the run has none)."""
        return self.summary.get(name, Estimate.missing())

    def group(self, category: str, group: str, metric: str) -> Estimate:
        """One category group's figure (``Estimate.missing()`` when absent)."""
        return self.per_category.get((category, group, metric), Estimate.missing())

    def groups(self, category: str, metric: str) -> list[tuple[str, Estimate]]:
        """Every group of ``category`` for ``metric``, in the scorer's order."""
        return [(g, e) for (c, g, m), e in self.per_category.items()
                if c == category and m == metric]

    def to_json(self) -> dict[str, Any]:
        """The run's JSON object."""
        return {
            "model": self.model, "split": self.split, "predictions": self.predictions,
            "kind": self.kind, "scorer": self.scorer,
            "summary": {m: e.to_json() for m, e in self.summary.items()},
            "per_step": [{"step": s, **e.to_json()} for s, e in self.per_step.items()],
            "per_category": [{"category": c, "group": g, "metric": m, **e.to_json()}
                             for (c, g, m), e in self.per_category.items()],
            "counts": self.counts,
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Run:
        """Parse a run object written by :meth:`to_json`."""
        return cls(
            model=str(data["model"]), split=str(data["split"]),
            predictions=str(data["predictions"]), kind=str(data["kind"]),
            scorer=str(data["scorer"]),
            summary={str(m): Estimate.from_json(e) for m, e in data["summary"].items()},
            per_step={int(r["step"]): Estimate.from_json(r) for r in data["per_step"]},
            per_category={(str(r["category"]), str(r["group"]), str(r["metric"])):
                          Estimate.from_json(r) for r in data["per_category"]},
            counts={str(k): int(v) for k, v in data.get("counts", {}).items()},
        )


def _nan(v: object) -> bool:
    return isinstance(v, float) and not math.isfinite(v)


@dataclass(frozen=True)
class Results:
    """Every run of one evaluation (or of the leaderboard), in a fixed order; with
    ``evaluate --robustness`` also the robustness suite's table of each part."""

    runs: tuple[Run, ...]
    robustness: tuple[Suite, ...] = ()

    def __post_init__(self) -> None:
        seen: set[tuple[str, str]] = set()
        for r in self.runs:
            if (r.model, r.split) in seen:
                msg = (f"model {r.model!r} is scored twice on {r.split}; a summary holds one "
                       "run per model and split part: drop one of the two predictions files")
                raise InvalidArgument(msg)
            seen.add((r.model, r.split))

    @property
    def models(self) -> list[str]:
        """Model ids in first-seen order."""
        return list(dict.fromkeys(r.model for r in self.runs))

    @property
    def splits(self) -> list[str]:
        """Split parts in first-seen order."""
        return list(dict.fromkeys(r.split for r in self.runs))

    def run(self, model: str, split: str) -> Run | None:
        """The run of ``model`` on ``split`` (a part such as ``paper-v2/test``), if any."""
        return next((r for r in self.runs if r.model == model and r.split == split), None)

    def on(self, split: str) -> list[Run]:
        """The runs on one split part."""
        return [r for r in self.runs if r.split == split]

    def to_json(self) -> dict[str, Any]:
        """The summary's JSON object."""
        out: dict[str, Any] = {"format": FORMAT, "schema_version": SCHEMA_VERSION,
                               "runs": [r.to_json() for r in self.runs]}
        if self.robustness:
            out["robustness"] = [s.to_dict() for s in self.robustness]
        return out

    def write(self, folder: str | os.PathLike[str]) -> Path:
        """Write ``folder/summary.json`` (canonical JSON: the same runs, the same bytes)."""
        return atomic_write_text(Path(folder) / SUMMARY_FILE,
                                 canonical_json(self.to_json()) + "\n")

    @classmethod
    def read(cls, where: str | os.PathLike[str]) -> Results:
        """Read a results folder (or its ``summary.json``)."""
        path = Path(where)
        if path.is_dir():
            path = path / SUMMARY_FILE
        if not path.is_file():
            msg = (f"{path} does not exist; a results folder is written by "
                   "`nsrmp-bench evaluate ... --out DIR` (or is leaderboards/site/)")
            raise InvalidArgument(msg)
        try:
            data = json.loads(path.read_text("utf-8"))
        except (OSError, ValueError) as exc:
            msg = f"{path} is not readable JSON ({exc}); rerun `nsrmp-bench evaluate`"
            raise InvalidArgument(msg) from exc
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            msg = (f"{path} is not an nsrmp-bench results summary (format "
                   f"{data.get('format') if isinstance(data, dict) else None!r}, expected "
                   f"{FORMAT!r}); pass the folder `nsrmp-bench evaluate --out` wrote")
            raise InvalidArgument(msg)
        check_schema_version(data.get("schema_version"), str(path),
                             supported=int(SCHEMA_VERSION.split(".")[0]))
        try:
            return cls(tuple(Run.from_json(r) for r in data["runs"]),
                       tuple(suite_from_dict(s, str(path)) for s in data.get("robustness", [])))
        except (KeyError, TypeError, ValueError) as exc:
            msg = f"{path}: a run lacks a field or has a bad value ({exc!r}); rerun evaluate"
            raise InvalidArgument(msg) from exc
