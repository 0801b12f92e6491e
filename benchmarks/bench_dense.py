"""Table II of the paper for the dense baselines (not CLIPort: dense-v2, dense5x-v2) and
NSRM: the public scorer's figures on paper-v2/test, with training time and parameter
counts (the retired dense-v1 and dense5x-v1 were measured so with nsrmp-bench 0.2.0).

Usage::

    OMP_WAIT_POLICY=PASSIVE .venv/bin/python benchmarks/bench_dense.py --data-root data \
        [--models dense-v2 dense5x-v2 nsrm] [--splits paper-v2] \
        [--out results/dense]

It runs ``nsrmp-bench evaluate`` (in this process: each model's shipped checkpoint through
``predict``, then the public scorer) on the given splits' test parts, prints identification
and placement (overall, simple, complex = relational; single-step instances only, with 95%
intervals) beside the paper's CLIPort rows, IoU-M per part, and each model's training time
and parameter count from its shipped card. The same Table II comes from
``nsrmp-bench report OUT --paper``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from nsrmp_bench.cli.evaluate import runners
from nsrmp_bench.engine import InlineEngine
from nsrmp_bench.results.evaluate import evaluate
from nsrmp_bench.results.model_cards import model_card
from nsrmp_bench.results.paper_tables import TABLE_II, render_markdown, row_label
from nsrmp_bench.results.summary import Estimate

PAPER = {"CLIPort": (0.46, 0.39), "CLIPort (5x)": (0.76, 0.61)}


def _ci(e: Estimate) -> str:
    return f"{e.value:.3f} [{e.low:.3f}, {e.high:.3f}]"


def main() -> None:
    """Evaluate and print."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data-root", type=Path, required=True)
    parser.add_argument("--models", nargs="+",
                        default=["dense-v2", "dense5x-v2", "nsrm"])
    parser.add_argument("--splits", nargs="+", default=["paper-v2"])
    parser.add_argument("--out", type=Path, default=Path("results/dense"))
    args = parser.parse_args()
    t0 = time.perf_counter()
    with InlineEngine() as engine:
        results = evaluate(args.models, args.data_root, args.out, splits=args.splits,
                           workers=1, engine=engine, say=print, runners=runners())
    print(f"\nevaluated in {time.perf_counter() - t0:.0f} s\n")
    tables = render_markdown(results, paper=True)
    print(tables[tables.index(f"**{TABLE_II.title}**"):])
    print("| model | id. overall [95% CI] | pl. overall [95% CI] | n |")
    print("|---|---|---|---|")
    for name, (pid, ppl) in PAPER.items():
        print(f"| paper: {name} | {pid:.2f} | {ppl:.2f} | |")
    for run in results.on("paper-v2/test"):
        ident, place = run.metric("identification"), run.metric("placement")
        print(f"| {row_label(run.model)} | {_ci(ident)} | {_ci(place)} | {ident.n} |")
    print("\n| model | part | IoU | IoU-M [95% CI] |\n|---|---|---|---|")
    for run in results.runs:
        print(f"| {run.model} | {run.split} | {run.metric('iou').value:.3f} | "
              f"{_ci(run.metric('iou_m'))} |")
    print("\n| model | training time | parameters | training data |\n|---|---|---|---|")
    for model in sorted({r.model for r in results.runs}):
        facts = model_card(model).facts
        print(f"| {row_label(model)} | {facts['training_time']} | {facts['parameters']} | "
              f"{facts['training_data']} |")


if __name__ == "__main__":
    main()
