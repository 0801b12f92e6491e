"""``nsrmp-bench report RESULTS --paper``: the paper's Table I and II from a results folder.

Example::

    nsrmp-bench report results --paper                  # prints Markdown, writes .md/.tex
    nsrmp-bench report leaderboards/site --paper --readme docs/results.md

Renders Table I (IoU, IoU-M, program accuracy; single/double step; simple/complex) and
Table II (identification and placement accuracy) in the paper's layout for every run on
paper-v2/test; ``--paper`` puts the paper's published rows above ours. Writes
``paper-tables.md`` and ``paper-tables.tex`` into ``--out`` (default: the results folder);
``--readme FILE`` also replaces the marked tables block of that Markdown file.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.results.paper_tables import render_markdown, replace_block, write_report
from nsrmp_bench.results.summary import Results
from nsrmp_bench.storage.atomic import atomic_write_text, output_dir

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("results", type=Path,
                        help="results folder (its summary.json), as evaluate wrote it")
    parser.add_argument("--paper", action="store_true",
                        help="put the paper's published rows beside ours")
    parser.add_argument("--out", type=output_dir, default=None,
                        help="folder for paper-tables.md/.tex (default: the results folder)")
    parser.add_argument("--readme", type=Path, default=None,
                        help="Markdown file whose marked tables block is replaced")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def run(args: argparse.Namespace) -> int:
    """Render, write, and print the Markdown."""
    results = Results.read(args.results)
    out = args.out if args.out is not None else (
        args.results if args.results.is_dir() else args.results.parent)
    md, tex = write_report(results, out, paper=args.paper)
    if args.readme is not None:
        text = args.readme.read_text("utf-8")
        atomic_write_text(args.readme, replace_block(
            text, render_markdown(results, paper=args.paper), str(args.readme)))
    if not args.quiet:
        print(md.read_text("utf-8"))
        print(f"wrote {md} and {tex}" + (f"; updated {args.readme}" if args.readme else ""))
    return 0
