"""``nsrmp-bench verify DATA``: check data against its manifest and the committed one.

Example::

    nsrmp-bench verify data/paper/test
    nsrmp-bench verify /shared/paper --engine dask --scheduler tcp://HOST:8786
    nsrmp-bench verify data/private/test --secret-file revealed.txt   # a private part

Recomputes every shard's sha256 and every episode's content hash; names what differs and
why (the manifests record the simulator and package versions and a physics fingerprint).
Shards are checked one task each, in this process by default (``--workers N``: a local
pool; ``--engine dask``: a Dask cluster).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rich.console import Console

from nsrmp_bench.cli.engine_options import add_engine_arguments, engine_from_args
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.plurals import counted
from nsrmp_bench.private_parts import read_secret
from nsrmp_bench.split_specs import load_split_file
from nsrmp_bench.storage.split_root import split_root_parts
from nsrmp_bench.verify import VerifyReport, verify

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("data", type=Path, nargs="+",
                        help="part directories (with manifest.json), or a split directory")
    parser.add_argument("--spec", type=Path, default=None, metavar="PATH",
                        help="a custom split's spec file: the data must have been made "
                             "from it")
    parser.add_argument("--secret-file", type=Path, default=None, metavar="PATH",
                        help="a private part's revealed secret: open its manifest's "
                             "commitment (default: $NSRMP_BENCH_SECRET, if set)")
    parser.add_argument("--shallow", action="store_true",
                        help="only shard sha256, not every episode's content hash")
    add_engine_arguments(parser, workers=1)


def _part_dirs(path: Path) -> list[Path]:
    if not path.is_dir():
        msg = (
            f"{path} is not a data directory; give a part directory (with manifest.json) "
            "or a split directory holding parts, as written by `nsrmp-bench generate`"
        )
        raise InvalidArgument(msg)
    return [path / p for p in split_root_parts(path)] or [path]


def run(args: argparse.Namespace) -> int:
    """Print one verdict per part; exit 1 if anything differs."""
    console = Console()
    spec = load_split_file(args.spec) if args.spec is not None else None
    secret = read_secret(args.secret_file)
    status = 0
    with engine_from_args(args) as engine:
        for given in args.data:
            for d in _part_dirs(given):
                report = verify(d, deep=not args.shallow, spec=spec, engine=engine,
                                secret=secret)
                _print(console, d, report)
                status = status or (0 if report.ok else 1)
    return status


def _print(console: Console, d: Path, report: VerifyReport) -> None:
    verdict = "[green]OK[/green]" if report.ok else "[red]DIFFERS[/red]"
    console.print(
        f"{report.split} ({d}): {verdict}: {counted(report.shards, 'shard')}, "
        f"{counted(report.episodes, 'episode')} rehashed, root {report.root_hash[:16]}"
    )
    if report.committed_root_hash is not None and report.ok:
        console.print("  matches the committed manifest" + (
            " (robot episodes within its stated tolerances)"
            if report.within_tolerance else ""))
    for line in report.problems:
        console.print(f"  - {line}")
    for line in report.notes:
        console.print(f"  {line}")
