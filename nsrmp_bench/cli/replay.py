"""``nsrmp-bench replay``: carry out a predictions file with the robot and write what it did.

Example::

    nsrmp-bench replay preds.jsonl --data data/smoke --out preds.robot.jsonl
    nsrmp-bench score preds.robot.jsonl --data data/smoke
    nsrmp-bench replay preds.jsonl --data /shared/paper/test --out r.jsonl --engine dask

For every predicted instance the episode's initial scene is put into the PyBullet world
and the Panda carries out the prediction by pick-and-place: a grounded ``program`` step
by step (steps the symbolic executor refuses are not attempted), else the predicted 3D
``positions``, else the predicted ``boxes`` back-projected through the episode's camera
onto the table or the object below (``--source`` picks one). The output is a predictions
file of the *achieved* final boxes (and positions, step boxes, pick/place), which the
normal scorer scores; instances without a prediction stay without one. ``--report``
writes each instance's moves, per-step success, errors and refusals as JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from nsrmp_bench.cli.engine_options import add_engine_arguments, engine_from_args
from nsrmp_bench.cli.numbers import positive_int
from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.plurals import counted
from nsrmp_bench.scoring.align import PredictionTable, align
from nsrmp_bench.scoring.gold import GoldTable, load_episodes
from nsrmp_bench.scoring.reader import read_submission_pending
from nsrmp_bench.scoring.submission import Prediction, SubmissionHeader, write_submission
from nsrmp_bench.storage.atomic import atomic_write_text
from nsrmp_bench.storage.split_root import part_of_split
from nsrmp_bench.vocabulary import ACTIONS

__all__ = ["add_arguments", "run"]

_SOURCES = ("auto", "program", "positions", "boxes")
_PROFILES = ("fast", "realistic")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("predictions", type=Path,
                        help="predictions file (.jsonl, .jsonl.gz or .parquet)")
    parser.add_argument("--data", required=True, type=Path,
                        help="the split's data (a data directory or shard, or a .jsonl of "
                             "symbolic episodes)")
    parser.add_argument("--out", required=True, type=Path,
                        help="where to write the achieved predictions "
                        "(.jsonl, .jsonl.gz or .parquet)")
    parser.add_argument("--split", default=None,
                        help="split id, when the data does not record it")
    parser.add_argument("--source", default="auto", choices=_SOURCES,
                        help="what to carry out: the program, the 3D positions or the boxes "
                             "(default auto: the first of these the line has)")
    parser.add_argument("--profile", default="fast", choices=_PROFILES,
                        help="robot motion profile (default fast)")
    add_engine_arguments(parser, workers=1)
    parser.add_argument("--limit", type=positive_int, default=None,
                        help="replay only the first N predicted instances (in data order)")
    parser.add_argument("--report", type=Path, default=None,
                        help="write per-instance replay details (moves, success, errors) as JSON")
    parser.add_argument("--render", type=Path, default=None,
                        help="write an initial | achieved image per instance into this folder")
    parser.add_argument("--allow-unknown-ids", action="store_true",
                        help="ignore lines whose id is not in the data instead of refusing")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def _program(table: PredictionTable, i: int) -> tuple[GroundedStep, ...] | None:
    if not table.has_program[i]:
        return None
    lo, hi = int(table.program_offsets[i]), int(table.program_offsets[i + 1])
    return tuple(
        GroundedStep(ACTIONS[int(table.actions[k])], int(table.subjects[k]),
                     int(table.references[k]))
        for k in range(lo, hi)
    )


def _tasks(episodes: list[Any], gold: GoldTable, table: PredictionTable,
           limit: int | None, make_task: Callable[..., Any]) -> Iterator[Any]:
    count = 0
    for i, ep in enumerate(episodes):
        if not table.present[i]:
            continue
        if limit is not None and count >= limit:
            return
        count += 1
        lo, hi = int(gold.obj_offsets[i]), int(gold.obj_offsets[i + 1])
        yield make_task(
            ep,
            _program(table, i),
            table.positions[lo:hi] if table.has_positions[i] else None,
            table.boxes[lo:hi],
            table.pick[i],
            table.place[i],
        )


def run(args: argparse.Namespace) -> int:
    """Replay, write the achieved predictions, report."""
    from nsrmp_bench._optional import require

    require("pybullet")
    if args.limit is not None and args.limit < 0:
        msg = f"--limit must be >= 0, got {args.limit}"
        raise InvalidArgument(msg)
    if args.out.resolve() == args.predictions.resolve():
        msg = f"--out {str(args.out)!r} is the input file; write the replay to another file"
        raise InvalidArgument(msg)
    from nsrmp_bench.generators.replay import batch
    from nsrmp_bench.generators.replay import episode as replay

    def make_task(ep: Any, *rows: Any) -> Any:
        return batch.ReplayTask(ep, replay.placements_from_rows(*rows))

    sub, pending = read_submission_pending(args.predictions)
    raw, recorded = load_episodes(args.data, part=part_of_split(sub.header.split))
    episodes = list(raw)
    gold = GoldTable.from_episodes(episodes, split=recorded or args.split, source=str(args.data))
    table = align(sub, gold, unknown_ids="warn" if args.allow_unknown_ids else "error",
                  pending=pending)
    tasks = list(_tasks(episodes, gold, table, args.limit, make_task))
    if not args.quiet:
        for warning in table.warnings:
            print(f"warning: {warning}", file=sys.stderr)

    def progress(done: int) -> None:
        if not args.quiet and (done % 10 == 0 or done == len(tasks)):
            print(f"  {done}/{len(tasks)}", file=sys.stderr)

    with engine_from_args(args) as engine:
        if not args.quiet:
            print(f"replaying {counted(len(tasks), 'instance')} of "
                  f"{gold.split or table.header.split} with the {args.profile} profile in "
                  f"{engine.describe()}", file=sys.stderr)
        outcomes = list(batch.replay_tasks(tasks, profile=args.profile, source=args.source,
                                           engine=engine, render_dir=args.render,
                                           progress=progress))
    predictions: list[Prediction] = [o.prediction for o in outcomes]
    failed = [o for o in outcomes if o.error is not None]
    header = SubmissionHeader(
        split=table.header.split,
        scorer=table.header.scorer,
        model=f"{table.header.model or 'unnamed'} (robot replay)",
        extra={"replay": {"executor": "robot-v1", "profile": args.profile,
                          "source": args.source, "of": args.predictions.name}},
    )
    write_submission(args.out, header, predictions)
    steps = [s for o in outcomes for s in o.summary.get("steps", [])]
    ok = sum(1 for s in steps if s["success"])
    errors = np.array([s["error_m"] for s in steps], dtype=np.float64)
    refused = sum(len(o.summary.get("plan", {}).get("refused", [])) for o in outcomes)
    totals = {
        "instances": len(outcomes),
        "written": len(predictions),
        "nothing_to_carry_out": len(failed),
        "moves": len(steps),
        "moves_succeeded": ok,
        "moves_refused": refused,
        "median_error_m": float(np.median(errors)) if len(errors) else None,
    }
    if args.report is not None:
        report = {"totals": totals, "instances": [o.summary for o in outcomes]}
        atomic_write_text(args.report, json.dumps(report, indent=1, allow_nan=False) + "\n")
    if not args.quiet:
        print(f"wrote {args.out}: {counted(len(predictions), 'instance')}; "
              f"{ok}/{counted(len(steps), 'move')} succeeded, {refused} refused; in "
              f"{counted(len(failed), 'instance')} nothing could be carried out (scene left "
              "as it was)",
              file=sys.stderr)
        for o in failed[:5]:
            print(f"  {o.episode_id}: {o.error}", file=sys.stderr)
    return 0
