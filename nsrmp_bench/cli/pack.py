"""``nsrmp-bench pack DATA --out RELEASE``: write the files a mirror hosts, and the registry.

Example::

    nsrmp-bench generate --split paper-v2 --out data/paper
    nsrmp-bench pack data/paper --out release/
    # host release/ on any static web server; users then run
    nsrmp-bench download --split paper-v2 --out data/paper --base-url https://host/release
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


def run(args: argparse.Namespace) -> int:
    """Copy the shards and manifests, write the registry, print the totals."""
    entries = pack(args.data, args.out)
    total = sum(e.bytes for e in entries)
    print(f"packed {counted(len(entries), 'file')} ({total / 1e6:.1f} MB) into {args.out}")
    return 0
