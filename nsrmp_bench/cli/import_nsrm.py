"""``nsrmp-bench import-nsrm DIR --out DATA``: convert the original NSRM release layout.

Per-example folders with ``demo.json`` and ``S00``/``S01`` PNGs become shards and a
manifest; examples without images are imported symbolic-only. Reading the PNGs needs
OpenCV (the ``sim`` extra).
"""

from __future__ import annotations

import argparse

from nsrmp_bench.cli.numbers import positive_int
from nsrmp_bench.plurals import counted
from nsrmp_bench.storage.atomic import output_dir


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("src", metavar="DIR", help="folder of the original release (searched "
                        "recursively for demo.json)")
    parser.add_argument("--out", required=True, type=output_dir, help="output data directory")
    parser.add_argument("--split", default="nsrm-original", help="split name to record")
    parser.add_argument("--shard-size", type=positive_int, default=1000, help="episodes per shard")
    parser.add_argument("--camera", default="auto",
                        choices=["auto", "small_table_view", "big_table_view_2"],
                        help="camera preset the images were rendered with (default: auto, "
                        "chosen per example by matching the masks)")
    parser.add_argument("--no-images", action="store_true",
                        help="import the symbolic part only")


def run(args: argparse.Namespace) -> int:
    """Import and print a summary."""
    from nsrmp_bench.storage.nsrm_import import import_nsrm

    report = import_nsrm(args.src, args.out, split=args.split, shard_size=args.shard_size,
                         camera=args.camera, images=not args.no_images)
    m = report.manifest
    print(
        f"imported {report.imported} examples ({report.with_images} with images) into "
        f"{args.out}: {counted(len(m.shards), 'shard')}, root hash {m.root_hash}"
    )
    for name in report.skipped:
        print(f"skipped {name}: no demo.json (the original generator failed after rendering)")
    return 0
