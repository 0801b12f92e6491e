"""``nsrmp-bench robustness MODEL... --data PART --out DIR``: the robustness suite.

Example::

    nsrmp-bench robustness nsrm nmn oracle --data data/paper-v2/test --out results/robust

Each model (learned model ids are run with ``predict``; baseline ids like ``baseline``) on
the part and on its perturbation by every kind (``--kinds``; default all, the blind and
shuffled controls included), made under ``DIR/parts/`` with the suite's seed. Prints and
writes (``DIR/robustness.json``, ``DIR/robustness.md``) one table: a row per model, a
column per kind with the paired IoU-M difference to the unperturbed part and its 95%
interval; the controls apart, as IoU-M. ``--board DIR`` also writes the table as a
leaderboard file (``<split>-<part>.json`` and ``.md``) there.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.cli.numbers import non_negative_int
from nsrmp_bench.robustness.kinds import KINDS
from nsrmp_bench.storage.atomic import output_dir

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("sources", nargs="+", metavar="MODEL",
                        help="learned model ids (nsrm, nmn, ...) and baseline ids (oracle, "
                        "noop, random)")
    parser.add_argument("--data", required=True, type=Path,
                        help="the unperturbed part (e.g. data/paper-v2/test)")
    parser.add_argument("--out", required=True, type=output_dir,
                        help="folder for the perturbed parts, predictions and the table")
    parser.add_argument("--kinds", nargs="+", choices=KINDS, default=list(KINDS),
                        metavar="KIND", help="kinds to run (default: all: "
                        + ", ".join(KINDS) + ")")
    parser.add_argument("--seed", type=non_negative_int, default=0,
                        help="perturbation seed (default 0, the suite's test seed)")
    parser.add_argument("--words", choices=("test", "dev"), default="test",
                        help="word lists: test (the suite's, default; boards) or dev (for "
                        "selecting a model on a development part)")
    parser.add_argument("--board", type=Path, default=None,
                        help="also write the table as a robustness board in this folder "
                        "(e.g. leaderboards/robustness)")
    parser.add_argument("--reuse", action="store_true",
                        help="score the predictions files already in DIR/predictions as "
                        "they are (remove one to predict it again)")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def render(suite: object) -> None:
    """Print the table: paired IoU-M differences per kind, the controls apart."""
    from rich.console import Console
    from rich.table import Table

    from nsrmp_bench.results.robustness_table import Suite

    assert isinstance(suite, Suite)
    t = Table(title=f"{suite.split}: paired IoU-M difference to the unperturbed part "
              "[95% CI]; controls: IoU-M", title_justify="left")
    head, rows = suite.table()
    for col in head:
        t.add_column(col, justify="left" if col == "model" else "right")
    for cells in rows:
        t.add_row(*cells)
    Console().print(t)


def run(args: argparse.Namespace) -> int:
    """Run the suite, print the table, write the files."""
    from nsrmp_bench.cli.evaluate import runners
    from nsrmp_bench.results.evaluate import resolve_source
    from nsrmp_bench.robustness.suite import run_suite
    from nsrmp_bench.storage.atomic import atomic_write_text

    run_with = runners()
    if any(resolve_source(s, run_with.models).kind == "model" for s in args.sources):
        from nsrmp_bench._optional import require

        require("torch")  # before anything is written
    say = None if args.quiet else print
    suite = run_suite(args.sources, args.data, args.out, kinds=args.kinds, seed=args.seed,
                      words=args.words, runners=run_with, say=say, reuse=args.reuse)
    if args.board is not None:
        stem = suite.split.replace("/", "-")
        args.board.mkdir(parents=True, exist_ok=True)
        suite.write(args.board / f"{stem}.json")
        atomic_write_text(args.board / f"{stem}.md",
                          f"# Robustness on {suite.split} (suite seed {suite.seed})\n\n"
                          "A row per model; per kind, the paired IoU-M difference to the "
                          "unperturbed part [95% interval]; the controls (blind, shuffled) "
                          "as IoU-M."
                          + (" Strict success and kept still (scorer-v2) on the unperturbed "
                             "part." if suite.has_strict else "")
                          + " Made by `nsrmp-bench robustness ... --board "
                          f"{args.board}`.\n\n" + suite.markdown())
    if not args.quiet:
        render(suite)
        print(f"wrote {args.out / 'robustness.json'} and {args.out / 'robustness.md'}")
    return 0
