"""``nsrmp-bench export-mcap DATA --out FILE.mcap [--episodes ID ...]``.

Writes stored episodes to MCAP with Foxglove well-known schemas (needs the ``mcap`` extra).
"""

from __future__ import annotations

import argparse

from nsrmp_bench.cli.numbers import positive_int
from nsrmp_bench.plurals import counted
from nsrmp_bench.storage.atomic import output_file


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("data", help="a shard file (*.h5) or a data directory with manifest.json")
    parser.add_argument("--out", required=True, type=output_file, help="the MCAP file to write")
    parser.add_argument("--episodes", nargs="+", metavar="ID",
                        help="export only these episode ids (default: all)")
    parser.add_argument("--chunk-size", type=positive_int, default=1 << 20,
                        help="uncompressed MCAP chunk size in bytes (default 1 MiB)")


def run(args: argparse.Namespace) -> int:
    """Export and print a one-line summary."""
    from nsrmp_bench._optional import require

    require("mcap")
    from nsrmp_bench.storage.mcap_export import export_mcap

    summary = export_mcap(args.data, args.out, episodes=args.episodes,
                          chunk_size=args.chunk_size)
    rate = summary.episodes / summary.seconds if summary.seconds > 0 else float("inf")
    print(
        f"wrote {summary.path}: {counted(summary.episodes, 'episode')}, "
        f"{counted(summary.messages, 'message')}, "
        f"{summary.bytes / 1e6:.2f} MB in {summary.seconds:.2f} s ({rate:.1f} episodes/s)"
    )
    return 0
