"""Scoring: the predictions format, its checks, the metrics of ``scorer-v2`` (and of
``scorer-v1``, the same figures without what stayed still and abstention), intervals.

``score(predictions, data)`` returns a :class:`ScoreResult` (pandas DataFrames per metric,
step, category and instance); ``compare(a, b, data)`` a paired :class:`Comparison`;
``check_submission(path, split=...)`` validates a file without scoring it. Needs only
numpy and pandas (pyarrow for Parquet files).
"""

from __future__ import annotations

from nsrmp_bench.scoring.check import CheckReport, check_submission
from nsrmp_bench.scoring.compare import Comparison, compare
from nsrmp_bench.scoring.gold import GoldTable, load_gold
from nsrmp_bench.scoring.metrics import METRICS, METRICS_V2
from nsrmp_bench.scoring.reader import read_submission
from nsrmp_bench.scoring.result import ScoreResult
from nsrmp_bench.scoring.scorer import score
from nsrmp_bench.scoring.submission import (
    Prediction,
    Submission,
    SubmissionHeader,
    load_schema,
    write_submission,
)
from nsrmp_bench.scoring.validate import parse_predictions
from nsrmp_bench.scoring.version import KNOWN_SCORERS, SCORER_ID, SUBMISSION_FORMAT_VERSION

__all__ = [
    "KNOWN_SCORERS",
    "METRICS",
    "METRICS_V2",
    "SCORER_ID",
    "SUBMISSION_FORMAT_VERSION",
    "CheckReport",
    "Comparison",
    "GoldTable",
    "Prediction",
    "ScoreResult",
    "Submission",
    "SubmissionHeader",
    "check_submission",
    "compare",
    "load_gold",
    "load_schema",
    "parse_predictions",
    "read_submission",
    "score",
    "write_submission",
]
