"""``nsrmp-bench baseline``: write a non-learned baseline's predictions for a split.

Example::

    nsrmp-bench baseline oracle --data data/smoke/test --out oracle.jsonl
    nsrmp-bench score oracle.jsonl --data data/smoke/test

Baselines: ``oracle`` (gold program executed symbolically: the upper bound), ``noop``
(nothing moves: the floor) and ``random`` (a random legal step per gold step, from
``--seed``). The file is an ordinary predictions file (.jsonl, or .parquet); made on a
data directory, its header states the protocol (no training, the part's root hash).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.baselines.registry import BASELINES, get_baseline, run_baseline
from nsrmp_bench.cli.numbers import non_negative_int
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scoring.gold import load_episodes
from nsrmp_bench.scoring.protocol_fields import part_root_hash
from nsrmp_bench.storage.atomic import output_file
from nsrmp_bench.storage.split_root import part_of_split

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    names = ", ".join(sorted({k.rsplit("-v", 1)[0] for k in BASELINES}))
    parser.add_argument("name", help=f"baseline: {names} (or an id such as oracle-v1)")
    parser.add_argument("--data", required=True, type=Path,
                        help="the split's data (a data directory or shard, or a .jsonl of "
                             "symbolic episodes)")
    parser.add_argument("--out", required=True, type=output_file, help="predictions file to write")
    parser.add_argument("--seed", type=non_negative_int, default=0,
                        help="seed (random baseline; default 0)")
    parser.add_argument("--split", default=None,
                        help="split id for the header, when the data does not record it")


def run(args: argparse.Namespace) -> int:
    """Predict every instance and write the file."""
    baseline = get_baseline(args.name)
    episodes, recorded = load_episodes(args.data)
    split = recorded or args.split
    if not split:
        msg = f"{args.data} records no split id; pass --split ID for the file's header"
        raise InvalidArgument(msg)
    root = part_root_hash(args.data, part_of_split(split)) if args.data.is_dir() else None
    out = run_baseline(baseline.id, episodes, args.out, split=split, seed=args.seed,
                       manifest_root_hash=root)
    print(f"{baseline.id}: wrote {out}")
    return 0
