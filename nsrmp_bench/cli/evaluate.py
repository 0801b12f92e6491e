"""``nsrmp-bench evaluate``: models and predictions files on every official test part.

Example::

    nsrmp-bench evaluate nsrm oracle noop random --data-root data --out results
    nsrmp-bench evaluate my-preds.jsonl --data-root data --out results
    nsrmp-bench evaluate nsrm oracle --data-root /shared/data --out /shared/results \
        --engine dask --scheduler tcp://HOST:8786
    nsrmp-bench plot results --out figures
    nsrmp-bench report results --paper

Model ids are run with ``predict`` (shipped checkpoint) and baseline ids like ``baseline``
on every official test part found as ``ROOT/<split id>/<part>`` (or ``ROOT/<name>/<part>``);
``--generate`` generates the missing ones first. A predictions file is scored on the part
its header names. Writes ``OUT/summary.json``, ``OUT/<split>-<part>.csv`` and
``OUT/predictions/``, and prints IoU-M with 95% intervals per model and split.
Each (source, part) run is one task, as is each shard of ``--generate``: ``--workers N``
runs them in a local pool (1: in this process), ``--engine dask`` on a Dask cluster; the
figures do not depend on where they ran.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from nsrmp_bench.cli.engine_options import add_engine_arguments, engine_from_args
from nsrmp_bench.results.evaluate import Runners, evaluate, resolve_source
from nsrmp_bench.results.summary import Results
from nsrmp_bench.storage.atomic import output_dir

if TYPE_CHECKING:
    from nsrmp_bench.engine import Engine

__all__ = ["add_arguments", "render_table", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("sources", nargs="+", metavar="MODEL_OR_PREDICTIONS",
                        help="learned model ids (nsrm, nmn, dense), baseline ids (oracle, "
                             "noop, random) or predictions files")
    parser.add_argument("--data-root", required=True, type=Path,
                        help="folder holding <split id>/<part>/ data (e.g. data/)")
    parser.add_argument("--out", required=True, type=output_dir,
                        help="results folder (summary.json, CSVs, predictions/)")
    parser.add_argument("--generate", action="store_true",
                        help="generate the official test parts missing under the root first")
    parser.add_argument("--splits", nargs="+", default=None, metavar="SPLIT_ID",
                        help="official split ids to run models and baselines on "
                             "(default: all official test parts found)")
    parser.add_argument("--robustness", action="store_true",
                        help="also run the robustness suite (every perturbation kind and the "
                        "controls) for the model and baseline ids on each test part: "
                        "OUT/robustness/<split>-<part>/, its tables in summary.json")
    add_engine_arguments(parser, workers=2)
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def render_table(results: Results) -> None:
    """Print IoU-M [95% CI] per model (rows) and split part (columns); under ``scorer-v2``
    strict success and kept still the same way."""
    from rich.console import Console
    from rich.table import Table

    scorers = sorted({r.scorer for r in results.runs})
    shown = [("iou_m", "IoU-M"), ("success_strict", "strict success"),
             ("kept_still", "kept still")]
    for metric, label in shown:
        if not any(metric in r.summary for r in results.runs):
            continue
        t = Table(title=f"{label} [95% CI] per split part (n instances) · "
                  f"{', '.join(scorers)}", title_justify="left")
        t.add_column("model")
        for split in results.splits:
            t.add_column(split, justify="right")
        for model in results.models:
            cells = []
            for split in results.splits:
                run = results.run(model, split)
                if run is None or metric not in run.summary:
                    cells.append("")
                    continue
                e = run.metric(metric)
                cells.append(f"{e.value:.3f} [{e.low:.3f}, {e.high:.3f}] ({e.n})")
            t.add_row(model, *cells)
        Console().print(t)


def _predict_part(model: str, data: Path, out: Path) -> object:
    """A learned model over a part (imported in the task: a worker may be another process)."""
    from nsrmp_bench.reference_model.part_prediction import predict_part

    return predict_part(model, data, out)


def _generate_part(split_id: str, part: str, out: Path, workers: int,
                   engine: Engine | None) -> object:
    from nsrmp_bench._optional import require
    from nsrmp_bench.split_specs import load_split

    require("pybullet")
    from nsrmp_bench.generators.generate import generate_part

    return generate_part(load_split(split_id), part, out, workers=workers, engine=engine)


def runners() -> Runners:
    """The learned models and the generator, for :func:`~nsrmp_bench.results.evaluate
    .evaluate` (the core does not import them)."""
    from nsrmp_bench.reference_model.registry import MODELS

    return Runners(models=tuple(MODELS), predict=_predict_part, generate=_generate_part)


def run(args: argparse.Namespace) -> int:
    """Evaluate, write the results folder, print the table."""
    say = None if args.quiet else print
    run_with = runners()
    if any(resolve_source(s, run_with.models).kind == "model" for s in args.sources):
        from nsrmp_bench._optional import require

        require("torch")  # before generating or scoring anything
    with engine_from_args(args) as engine:
        results = evaluate(args.sources, args.data_root, args.out, generate=args.generate,
                           splits=args.splits, workers=args.workers, engine=engine, say=say,
                           runners=run_with)
    if args.robustness:
        results = _with_robustness(results, args, run_with, say)
    if not args.quiet:
        render_table(results)
        print(f"wrote {args.out / 'summary.json'} and {len(results.splits)} CSV files")
    return 0


def _with_robustness(results: Results, args: argparse.Namespace, run_with: Runners,
                     say: Callable[[str], None] | None) -> Results:
    """The robustness suite of the model and baseline sources on every part evaluated,
    added to the summary (and printed)."""
    import dataclasses

    from nsrmp_bench.cli.robustness import render
    from nsrmp_bench.robustness.suite import run_suite
    from nsrmp_bench.storage.split_root import find_part

    ids = [s for s in args.sources if resolve_source(s, run_with.models).kind != "file"]
    if not ids:
        return results
    suites = []
    for split_part in results.splits:
        data = find_part(args.data_root, split_part)
        if data is None:
            continue
        out = args.out / "robustness" / split_part.replace("/", "-")
        suites.append(run_suite(ids, data, out, runners=run_with, say=say))
        if say is not None:
            render(suites[-1])
    results = dataclasses.replace(results, robustness=tuple(suites))
    results.write(args.out)
    return results
