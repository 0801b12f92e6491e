"""``nsrmp-bench plot RESULTS --out FIGURES``: the generalisation figures as PNG and SVG.

Example::

    nsrmp-bench evaluate nsrm oracle noop random --data-root data --out results
    nsrmp-bench plot results --out figures
    nsrmp-bench plot leaderboards/site --out figures      # the committed leaderboard runs

Draws IoU-M with 95% interval bands against the number of objects (paper-v2 then
objects-v2) and of steps (paper-v2 then steps-v2), one line per model, and a bar chart per
category (relational, phrasing, held-out language, held-out attribute pairs). Needs the
``plot`` extra (matplotlib); no torch or PyBullet.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.results.figures import draw_figures
from nsrmp_bench.results.summary import Results
from nsrmp_bench.storage.atomic import output_dir

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("results", type=Path,
                        help="results folder (its summary.json), as evaluate wrote it")
    parser.add_argument("--out", required=True, type=output_dir, help="folder for the figures")


def run(args: argparse.Namespace) -> int:
    """Draw and list the files."""
    for path in draw_figures(Results.read(args.results), args.out):
        print(path)
    return 0
