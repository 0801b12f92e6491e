"""``score(predictions, data)``: read, check, match, measure, and bootstrap.

The public entry point of scoring; the ``score`` command and the leaderboard call it, and
so do the baselines' evaluations. Only numpy, pandas (and h5py through the storage reader)
are needed.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nsrmp_bench.episode import Episode, SymbolicEpisode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scoring.align import PredictionTable, align
from nsrmp_bench.scoring.bootstrap import bootstrap_intervals, resampling_method
from nsrmp_bench.scoring.gold import GoldTable, load_gold
from nsrmp_bench.scoring.metrics import METRICS_V2, instance_scores, step_metric_name
from nsrmp_bench.scoring.read_limits import ReadLimits
from nsrmp_bench.scoring.reader import claimed_split, read_submission_pending
from nsrmp_bench.scoring.result import ScoreResult
from nsrmp_bench.scoring.submission import Prediction, Submission, SubmissionHeader
from nsrmp_bench.scoring.validate import Problems, parse_predictions
from nsrmp_bench.scoring.version import SCORER_ID, check_scorer
from nsrmp_bench.storage.split_root import part_of_split

__all__ = [
    "DEFAULT_N_BOOT",
    "DEFAULT_SEED",
    "gold_limits",
    "metric_columns",
    "prepare",
    "read_predictions",
    "score",
]

DEFAULT_SEED = 0
"""Seed of the bootstrap's Generator unless another is given (results are reproducible)."""

DEFAULT_N_BOOT = 1000
"""Bootstrap resamples per interval."""

Data = GoldTable | str | Path | Iterable[Episode | SymbolicEpisode]
Predictions = Submission | str | Path | Sequence[Prediction]


def metric_columns(gold: GoldTable, frame: pd.DataFrame) -> list[str]:
    """The figure columns of a per-instance frame (of either scorer), in report order."""
    cols = [m.name for m in METRICS_V2 if m.name in frame.columns]
    cols += [step_metric_name(k) for k in range(1, gold.max_steps + 1)
             if step_metric_name(k) in frame.columns]
    return cols


def read_predictions(predictions: Predictions, *, split: str | None = None,
                     limits: ReadLimits | None = None) -> tuple[Submission, Problems | None]:
    """A parsed submission and the problems found reading it (None when given parsed).

    ``predictions`` is a file path, a parsed :class:`Submission`, or a list of
    :class:`Prediction` (checked like a file; ``split`` is its header's split). A file is
    read within ``limits`` (default: its split's committed manifest's).
    """
    if isinstance(predictions, Submission):
        return predictions, None
    if isinstance(predictions, str | Path):
        return read_submission_pending(predictions, limits=limits)
    if isinstance(predictions, Sequence):
        wrong = next((i for i, p in enumerate(predictions) if not isinstance(p, Prediction)),
                     None)
        if wrong is not None:
            msg = (f"predictions[{wrong}] is a {type(predictions[wrong]).__name__}, not a "
                   "Prediction; pass nsrmp_bench.scoring.submission.Prediction objects, a "
                   "predictions file's path, or a parsed Submission")
            raise InvalidArgument(msg)
        if not split:
            msg = ("a list of predictions has no header to name its split; pass "
                   "split='smoke-v2/test' (the split part they were made on), or score data "
                   "that records its split (a data directory or nsrmp_bench.open(...))")
            raise InvalidArgument(msg)
        checked = [p for p in predictions if isinstance(p, Prediction)]
        return parse_predictions(SubmissionHeader(split=split), checked,
                                 source="<list of predictions>"), None
    msg = (f"predictions must be a file path, a list of Prediction or a parsed Submission, "
           f"got {type(predictions).__name__}")
    raise InvalidArgument(msg)


def gold_limits(gold: GoldTable, unknown_ids: str = "error") -> ReadLimits:
    """The bounds of reading a predictions file for ``gold``'s instances; a file allowed to
    hold other ids (``unknown_ids="warn"``) gets the fixed bounds of an unknown part."""
    if unknown_ids != "error":
        return ReadLimits.unknown_part()
    return ReadLimits.for_arrays(gold.split or gold.source or "the data given", gold.n_objects,
                                 gold.n_steps)


def prepare(
    predictions: Predictions | tuple[Submission, Problems | None],
    gold: GoldTable,
    *,
    unknown_ids: str = "error",
    scorer: str = SCORER_ID,
) -> tuple[PredictionTable, pd.DataFrame, dict[str, int]]:
    """Read and check ``predictions`` (or a :func:`read_predictions` result), match them to
    ``gold``, and compute per-instance values of ``scorer``'s figures."""
    sub, pending = (predictions if isinstance(predictions, tuple)
                    else read_predictions(predictions))
    table = align(sub, gold, unknown_ids=unknown_ids, pending=pending)
    frame, source_counts = instance_scores(gold, table, scorer=scorer)
    return table, frame, {**table.counts, **source_counts}


def _groupings(gold: GoldTable) -> list[tuple[str, list[str], NDArray[np.int64]]]:
    out = []
    for col in gold.categories.columns:
        codes, uniques = pd.factorize(gold.categories[col], sort=True)
        if (codes < 0).any():  # missing labels get their own group
            codes = np.where(codes < 0, len(uniques), codes)
            labels = [str(u) for u in uniques] + ["(none)"]
        else:
            labels = [str(u) for u in uniques]
        out.append((str(col), labels, codes.astype(np.int64)))
    return out


def summarise(
    gold: GoldTable,
    frame: pd.DataFrame,
    *,
    seed: int | np.random.Generator = DEFAULT_SEED,
    n_boot: int = DEFAULT_N_BOOT,
    level: float = 0.95,
    breakdown: bool = True,
    breakdown_intervals: bool = True,
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Summary, per-step and per-category tables (means, bootstrap intervals, counts)."""
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    cols = metric_columns(gold, frame)
    values = frame[cols].to_numpy(dtype=np.float64)
    groupings = _groupings(gold) if breakdown else []
    overall, groups = bootstrap_intervals(
        values, rng, n_boot=n_boot, level=level,
        groupings=[(codes, len(labels)) for _, labels, codes in groupings],
        group_intervals=breakdown_intervals,
    )
    specs = {m.name: m for m in METRICS_V2}
    rows = []
    step_rows = []
    for i, c in enumerate(cols):
        entry = {
            "value": overall.mean[i],
            "ci_low": overall.low[i],
            "ci_high": overall.high[i],
            "n": int(overall.n[i]),
        }
        if c in specs:
            spec = specs[c]
            rows.append({"metric": c, "label": spec.label, **entry, "paper": spec.paper,
                         "description": spec.description})
        else:
            step_rows.append({"step": int(c.rsplit("_", 1)[1]), **entry})
    summary = pd.DataFrame(rows).set_index("metric")
    per_step = (
        pd.DataFrame(step_rows).set_index("step")
        if step_rows
        else pd.DataFrame(
            columns=["value", "ci_low", "ci_high", "n"], index=pd.Index([], name="step")
        )
    )
    cat_rows = []
    for (name, labels, _), g in zip(groupings, groups, strict=True):
        for gi, label in enumerate(labels):
            for i, c in enumerate(cols):
                cat_rows.append({
                    "category": name, "group": label, "metric": c,
                    "value": g.mean[gi, i], "ci_low": g.low[gi, i], "ci_high": g.high[gi, i],
                    "n": int(g.n[gi, i]),
                })
    per_category = pd.DataFrame(
        cat_rows, columns=["category", "group", "metric", "value", "ci_low", "ci_high", "n"]
    )
    return summary, per_step, per_category


def score(
    predictions: Predictions,
    data: Data,
    *,
    seed: int | np.random.Generator = DEFAULT_SEED,
    n_boot: int = DEFAULT_N_BOOT,
    level: float = 0.95,
    breakdown: bool = True,
    breakdown_intervals: bool = True,
    unknown_ids: str = "error",
    split: str | None = None,
    scorer: str = SCORER_ID,
) -> ScoreResult:
    """Score predictions against a split's data.

    ``predictions`` is a predictions file's path, a list of
    :class:`~nsrmp_bench.scoring.submission.Prediction` (checked exactly like a file; their
    split is the data's, or ``split``), or a parsed :class:`Submission`
    (:func:`~nsrmp_bench.scoring.validate.parse_predictions`). ``data`` is a data file
    path, an open collection (``nsrmp_bench.open(path)``: it knows its split), an iterable
    of episodes, or a built :class:`GoldTable` (``split`` names it when it records no
    split id); a split root is read at the part
    the predictions' header names (``smoke-v2/test``). Intervals are percentile bootstrap
    intervals at ``level`` from ``n_boot`` resamples of a Generator seeded with ``seed``
    (0 resamples: no intervals). ``breakdown=False`` skips the per-category tables and
    ``breakdown_intervals=False`` only their intervals (the costly part on huge splits).
    ``unknown_ids="warn"`` ignores (and counts) lines for ids outside the split instead of
    refusing the file. ``scorer`` picks the figures: ``"scorer-v2"`` (the default) or
    ``"scorer-v1"`` (its figures only, with the same values), whichever scorer the file's
    header names. Raises :class:`~nsrmp_bench.errors.SubmissionError` for a bad file.
    """
    check_scorer(scorer)
    if isinstance(predictions, Sequence) and not isinstance(predictions, str):
        gold = load_gold(data, split=split)  # the header's split comes from the data
        read = read_predictions(predictions, split=gold.split or split)
    elif isinstance(predictions, str | Path) and (claimed := claimed_split(predictions)):
        gold = load_gold(data, split=split, part=part_of_split(claimed))
        read = read_predictions(predictions, limits=gold_limits(gold, unknown_ids))
    else:
        read = read_predictions(predictions)
        gold = load_gold(data, split=split, part=part_of_split(read[0].header.split))
    table, frame, counts = prepare(read, gold, unknown_ids=unknown_ids, scorer=scorer)
    summary, per_step, per_category = summarise(
        gold, frame, seed=seed, n_boot=n_boot, level=level, breakdown=breakdown,
        breakdown_intervals=breakdown_intervals,
    )
    settings: dict[str, Any] = {
        "n_boot": n_boot,
        "level": level,
        "seed": seed if isinstance(seed, int) else "generator",
        "interval": "percentile bootstrap over instances",
        "resampling": resampling_method(gold.n_instances),
        "unknown_ids": unknown_ids,
        "breakdown_intervals": breakdown and breakdown_intervals,
    }
    return ScoreResult(
        scorer=scorer,
        split=gold.split or table.header.split,
        source=table.source,
        model=table.header.model,
        summary=summary,
        per_step=per_step,
        per_category=per_category,
        per_instance=frame,
        counts=counts,
        warnings=table.warnings,
        settings=settings,
    )
