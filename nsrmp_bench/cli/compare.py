"""``nsrmp-bench compare``: paired differences between two submissions on one split.

Example::

    nsrmp-bench compare model.jsonl noop.jsonl --data data/smoke/test --json diff.json

For every metric of ``--scorer`` (default ``scorer-v2``): A, B, the mean difference A - B
over the same instances with a paired bootstrap interval, and the p-value of a two-sided
paired sign-flip permutation test.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.cli.numbers import non_negative_int
from nsrmp_bench.cli.score import add_common
from nsrmp_bench.scoring.compare import DEFAULT_N_PERM, compare

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("a", type=Path, help="predictions file A")
    parser.add_argument("b", type=Path, help="predictions file B")
    add_common(parser)
    parser.add_argument("--n-perm", type=non_negative_int, default=DEFAULT_N_PERM,
                        help=f"random sign flips of the test (default {DEFAULT_N_PERM})")


def run(args: argparse.Namespace) -> int:
    """Compare, print, and write JSON if asked."""
    result = compare(
        args.a, args.b, args.data, seed=args.seed, n_boot=args.n_boot, n_perm=args.n_perm,
        level=args.level, split=args.split,
        unknown_ids="warn" if args.allow_unknown_ids else "error", scorer=args.scorer,
    )
    if not args.quiet:
        result.render()
    if args.json is not None:
        result.write_json(args.json)
    return 0
