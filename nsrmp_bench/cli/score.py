"""``nsrmp-bench score``: score a predictions file against a split's data.

Example::

    nsrmp-bench score predictions.jsonl --data data/smoke/test --json scores.json

Prints the figures of ``--scorer`` (default ``scorer-v2``; IoU-M first, with 95%
bootstrap intervals and instance counts), IoU-M after each step, and the breakdown by
steps, objects, relational and phrasing (``--breakdown all`` adds the rest: relation
needed, template, phenomenon); ``--json`` writes all of it. A malformed file is refused
with every problem listed by line. ``--data`` may be the split root ``generate --out``
wrote: the part the header names is read. A file whose header protocol names another
manifest than the data's is refused, as ``check-submission`` refuses it;
``--allow-other-manifest`` scores it on purpose (cross-scoring).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.cli.numbers import non_negative_int
from nsrmp_bench.errors import SubmissionError
from nsrmp_bench.scoring.made_on import refuse_other_manifest
from nsrmp_bench.scoring.result import BREAKDOWNS
from nsrmp_bench.scoring.scorer import DEFAULT_N_BOOT, DEFAULT_SEED, score
from nsrmp_bench.scoring.version import KNOWN_SCORERS, SCORER_ID
from nsrmp_bench.storage.atomic import atomic_path, output_file

__all__ = ["add_arguments", "run"]


def add_common(parser: argparse.ArgumentParser) -> None:
    """Arguments shared by ``score`` and ``compare``."""
    parser.add_argument("--data", required=True, type=Path,
                        help="the split's data (a data directory or shard, or a .jsonl of "
                             "symbolic episodes)")
    parser.add_argument("--split", default=None,
                        help="split id, when the data does not record it")
    parser.add_argument("--seed", type=non_negative_int, default=DEFAULT_SEED,
                        help=f"seed of the bootstrap (default {DEFAULT_SEED})")
    parser.add_argument("--n-boot", type=non_negative_int, default=DEFAULT_N_BOOT,
                        help=f"bootstrap resamples (default {DEFAULT_N_BOOT}; 0: no intervals)")
    parser.add_argument("--level", type=float, default=0.95,
                        help="confidence level of the intervals (default 0.95)")
    parser.add_argument("--allow-unknown-ids", action="store_true",
                        help="ignore (and count) lines whose id is not in the split instead "
                             "of refusing the file")
    parser.add_argument("--scorer", choices=KNOWN_SCORERS, default=SCORER_ID,
                        help=f"the figures to report (default {SCORER_ID}: scorer-v1's, with "
                             "the same values, plus strict success, kept still and "
                             "abstention); a file written for either scorer is scored by "
                             "either")
    parser.add_argument("--json", type=output_file, default=None, help="write the figures as JSON")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("predictions", type=Path,
                        help="predictions file (.jsonl, .jsonl.gz or .parquet)")
    add_common(parser)
    parser.add_argument("--breakdown", choices=BREAKDOWNS, default="short",
                        help="categories of the printed breakdown: short (steps, objects, "
                             "relational, phrasing; the default), all (templates too) or "
                             "none; --json always holds every one")
    parser.add_argument("--no-breakdown", action="store_true",
                        help="skip computing the per-category breakdown")
    parser.add_argument("--no-breakdown-intervals", action="store_true",
                        help="breakdown means and counts only, no intervals (much faster on "
                             "huge splits)")
    parser.add_argument("--per-instance", type=output_file, default=None,
                        help="also write each instance's values (.csv, or .parquet)")
    parser.add_argument("--allow-other-manifest", action="store_true",
                        help="score predictions whose header protocol names another "
                             "manifest than the data's (deliberate cross-scoring)")


def run(args: argparse.Namespace) -> int:
    """Score, print, and write what was asked for."""
    if not args.allow_other_manifest:
        refuse_other_manifest(args.predictions, args.data)
    result = score(
        args.predictions, args.data, seed=args.seed, n_boot=args.n_boot, level=args.level,
        breakdown=not args.no_breakdown,
        breakdown_intervals=not args.no_breakdown_intervals, split=args.split,
        unknown_ids="warn" if args.allow_unknown_ids else "error", scorer=args.scorer,
    )
    if not result.counts.get("predicted", 0):
        msg = (f"{args.predictions}: not one instance of {result.split or 'the data'} is "
               "predicted (a header without predictions, or only unknown ids); it would score "
               "zero: write one line per instance after the header")
        raise SubmissionError(msg)
    if not args.quiet:
        result.render(breakdown=args.breakdown)
    if args.json is not None:
        result.write_json(args.json)
    if args.per_instance is not None:
        if args.per_instance.suffix == ".parquet":
            from nsrmp_bench._optional import require

            require("pyarrow")
            with atomic_path(args.per_instance) as tmp:
                result.per_instance.to_parquet(tmp)
        else:
            with atomic_path(args.per_instance) as tmp:
                result.per_instance.to_csv(tmp)
    return 0
