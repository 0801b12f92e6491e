"""Version ids of the scorer and of the predictions file format.

A change to any metric's definition makes a new scorer id and the old one stays
available and documented. ``scorer-v2`` (the default) adds what stayed still
(``kept_still``, ``success_strict``) and abstention to ``scorer-v1``'s figures, every one
of which keeps its value. A predictions file names the scorer it was written for; a file
for either known scorer is scored by either (``score --scorer``), a file for an unknown one
is refused rather than scored under different rules.
"""

from __future__ import annotations

import difflib
from typing import Final

from nsrmp_bench.errors import InvalidArgument

__all__ = [
    "ABSTAIN_FORMAT_VERSION",
    "ABSTAIN_SCORER_ID",
    "BASE_FORMAT_VERSION",
    "KNOWN_SCORERS",
    "SCORER_ID",
    "SCORER_V1",
    "SCORER_V2",
    "SUBMISSION_FORMAT",
    "SUBMISSION_FORMAT_VERSION",
    "WRITTEN_SCORER_ID",
    "check_scorer",
]

SCORER_V1: Final = "scorer-v1"
"""The paper's figures and ours (IoU-M, success, programs, ...), as first released."""

SCORER_V2: Final = "scorer-v2"
"""``scorer-v1``'s figures (same values) plus ``kept_still``, ``success_strict``, ``abstention``."""

SCORER_ID: Final = SCORER_V2
"""The scorer used unless another is asked for (see ``nsrmp_bench.scoring.metrics``)."""

KNOWN_SCORERS: Final = (SCORER_V1, SCORER_V2)
"""Every scorer id this package can score a file for (and score a file with)."""

WRITTEN_SCORER_ID: Final = SCORER_V1
"""The scorer a writer names in a header (and a protocol) by default: a file that uses no
``abstain`` is a valid ``scorer-v1`` file, so predictions written before ``scorer-v2``
(the committed ones) are written again byte for byte. A file whose lines use ``abstain``
is written for :data:`ABSTAIN_SCORER_ID` (``write_submission``)."""

ABSTAIN_SCORER_ID: Final = SCORER_V2
"""The scorer a file that uses ``abstain`` is written for."""

SUBMISSION_FORMAT: Final = "nsrmp-bench-predictions"
"""The ``format`` value of a predictions file's header."""

SUBMISSION_FORMAT_VERSION: Final = "1.1.0"
"""Semantic version of the predictions file format; readers refuse another major version.
1.1.0 adds the optional ``abstain`` field of a line; 1.0.0 files read unchanged."""

BASE_FORMAT_VERSION: Final = "1.0.0"
"""The version a writer names for a file without ``abstain`` (it is a valid 1.0.0 file)."""

ABSTAIN_FORMAT_VERSION: Final = "1.1.0"
"""The first format version with ``abstain``; a writer names it for a file that uses it."""


def check_scorer(scorer: str) -> str:
    """``scorer`` if it is a known scorer id, else InvalidArgument naming the known ones."""
    if scorer not in KNOWN_SCORERS:
        close = difflib.get_close_matches(str(scorer), KNOWN_SCORERS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        msg = f"unknown scorer {scorer!r}{hint}; this nsrmp-bench scores {list(KNOWN_SCORERS)}"
        raise InvalidArgument(msg)
    return scorer
