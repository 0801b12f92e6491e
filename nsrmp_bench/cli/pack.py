"""``nsrmp-bench pack DATA --out RELEASE``: write the files a mirror hosts, and the registry.

Example::

    nsrmp-bench generate --split paper-v2 --out data/paper
    nsrmp-bench pack data/paper --out release/
    # host release/ on any static web server; users then run
    nsrmp-bench download --split paper-v2 --out data/paper --base-url https://host/release
    nsrmp-bench pack data/private --out challenge/ --inputs-only   # no gold: for a server

With ``--inputs-only`` every part is written without its gold (no targets, final states,
programs, seeds or physics reports): what a challenge's participants download, while the
scoring server keeps the full part. ``EpisodeDataset`` and ``predict`` read it as usual.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.plurals import counted
from nsrmp_bench.release import pack
from nsrmp_bench.storage.atomic import output_dir

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("data", type=Path, help="a generated split directory (or one part)")
    parser.add_argument("--out", type=output_dir, required=True, help="release directory")
    parser.add_argument("--inputs-only", action="store_true",
                        help="leave the gold out (targets, final states, programs, seeds): "
                        "the public copy of a test scored by a server")


def run(args: argparse.Namespace) -> int:
    """Copy the shards and manifests, write the registry, print the totals."""
    entries = pack(args.data, args.out, inputs_only=args.inputs_only)
    total = sum(e.bytes for e in entries)
    print(f"packed {counted(len(entries), 'file')} ({total / 1e6:.1f} MB) into {args.out}")
    return 0
