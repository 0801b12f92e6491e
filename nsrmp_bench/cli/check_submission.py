"""``nsrmp-bench check-submission``: validate a predictions file without scoring it.

Example::

    nsrmp-bench check-submission predictions.jsonl --split smoke-v2 --data data/smoke/test

Without ``--data`` the file is checked on its own (header, JSON, fields, types, numbers,
programs, duplicates) and, for an official split, its ids and box counts against the
committed manifest; with it, also step counts and image bounds. Exit status 0 when valid;
2 with every problem listed by line otherwise (a file without any prediction included).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.scoring.check import check_submission

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("predictions", type=Path,
                        help="predictions file (.jsonl, .jsonl.gz or .parquet)")
    parser.add_argument("--split", required=True, help="the split id the file must be for")
    parser.add_argument("--data", type=Path, default=None,
                        help="the split's data, to check ids, counts and image bounds too")
    parser.add_argument("--allow-unknown-ids", action="store_true",
                        help="count lines whose id is not in the split instead of failing")


def run(args: argparse.Namespace) -> int:
    """Check and print the outcome."""
    report = check_submission(
        args.predictions, split=args.split, data=args.data,
        unknown_ids="warn" if args.allow_unknown_ids else "error",
    )
    print(report.summary())
    return 0
