"""Version ids of the scorer and of the predictions file format.

A change to any metric's definition makes a new scorer id (``scorer-v2``) and the old one
stays documented; a predictions file names the scorer it was written for, and a file for
another scorer is refused rather than scored under different rules.
"""

from __future__ import annotations

from typing import Final

__all__ = [
    "KNOWN_SCORERS",
    "SCORER_ID",
    "SUBMISSION_FORMAT",
    "SUBMISSION_FORMAT_VERSION",
]

SCORER_ID: Final = "scorer-v1"
"""The metric definitions this package implements (see ``nsrmp_bench.scoring.metrics``)."""

KNOWN_SCORERS: Final = (SCORER_ID,)
"""Every scorer id this package can score a file for."""

SUBMISSION_FORMAT: Final = "nsrmp-bench-predictions"
"""The ``format`` value of a predictions file's header."""

SUBMISSION_FORMAT_VERSION: Final = "1.0.0"
"""Semantic version of the predictions file format; readers refuse another major version."""
