"""``nsrmp-bench export-hf DATA --out DIR``: the split as Hugging Face datasets Parquet.

Example::

    nsrmp-bench export-hf data/smoke --out hf/smoke
    python -c "from datasets import load_dataset; print(load_dataset('hf/smoke'))"
    huggingface-cli upload USER/nsrmp-smoke hf/smoke --repo-type dataset

Writes one Parquet file per HDF5 shard under ``DIR/<part>/`` (datasets' own writer, images
as Image features) and a dataset card ``DIR/README.md`` whose ``configs`` name the split
and map each part to a datasets split. ``DIR`` must be new or empty; the export is written
to a temporary folder beside it and renamed when complete. Needs the ``export`` extra.
"""

from __future__ import annotations

import argparse
import sys

from nsrmp_bench.cli.export_args import add_arguments

__all__ = ["add_arguments", "run"]


def run(args: argparse.Namespace) -> int:
    """Export and print what was written."""
    from nsrmp_bench.export.hf import export_hf

    files = export_hf(args.data, args.out)
    if not args.quiet:
        print(f"wrote {len(files)} Parquet file(s) and README.md into {args.out}",
              file=sys.stderr)
    return 0
