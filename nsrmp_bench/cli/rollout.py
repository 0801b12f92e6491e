"""``nsrmp-bench rollout POLICY``: run a policy in closed loop on every instance of a part.

Example::

    nsrmp-bench rollout oracle --data data/smoke/test --out oracle.closed.jsonl
    nsrmp-bench score oracle.closed.jsonl --data data/smoke/test
    nsrmp-bench rollout my_pkg.policies:policy --data data/smoke --part test --out p.jsonl
    nsrmp-bench rollout oracle --split smoke-v2 --part test --out p.jsonl   # generated here
    nsrmp-bench rollout dense --boxes classical --data data/smoke/test --out dense.jsonl

``POLICY`` is ``oracle`` (the gold program, one step at a time), ``noop``, ``nsrm`` or
``nmn`` (a shipped program model's predicted program, one step at a time, each target
on the real state; these read the gold boxes), ``dense`` (the shipped dense baseline: a
pick and a place point per step on the current observation; it reads the gold boxes, or
a detector's with ``--boxes classical|learned``) or ``module:function``, any callable
``policy(observation) -> action`` (see ``nsrmp_bench.envs.policies``). Every instance
runs in the Gymnasium environment ``nsrmp_bench/Tabletop-v0`` (teleport executor, or the
Panda with ``--executor robot``) until the policy says done or the instruction's step
count plus ``--step-margin`` moves have been made. The output is an ordinary predictions
file of the achieved final boxes (and positions, step boxes, program when every move was
a DSL step), which ``score`` scores. ``--report`` writes each instance's success, move
count and failures as JSON. A ``module:function`` policy must be importable by the
workers (on ``PYTHONPATH``) when ``--workers`` > 1.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from nsrmp_bench.cli.engine_options import add_engine_arguments, engine_from_args
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scoring.submission import SubmissionHeader, write_submission

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("policy", nargs="?", default=None,
                        help="a registered predictor (oracle, noop, random, nsrm, nmn, dense, "
                             "or an id such as nsrm-v2), or module:function (a callable "
                             "policy(observation) -> action); with --server, optional (the "
                             "server says its policy; given, it must match)")
    parser.add_argument("--data", type=Path, default=None,
                        help="a generated part directory (or a split root with --part)")
    parser.add_argument("--split", default=None,
                        help="without --data: a split id or spec file, generated on the fly")
    parser.add_argument("--part", default=None,
                        help="the part to run (default: the part --data is, else 'test')")
    parser.add_argument("--out", required=True, type=Path,
                        help="predictions file to write (.jsonl, .jsonl.gz or .parquet)")
    parser.add_argument("--executor", default="teleport", choices=("teleport", "robot"),
                        help="how moves are carried out (default teleport)")
    parser.add_argument("--boxes", default=None, choices=("gold", "classical", "learned"),
                        help="boxes in the observation: the current gold ones, or a "
                             "detector's on the current image (nsrm, nmn, dense: gold "
                             "unless given)")
    parser.add_argument("--control", default="pick_place", choices=("pick_place", "ee"),
                        help="the action: whole moves (pick and place points or DSL steps; "
                             "default) or ee, end-effector pose changes and a gripper "
                             "command at 10 Hz, the Panda executing (oracle-ee)")
    parser.add_argument("--step-margin", type=int, default=2,
                        help="moves allowed beyond the instruction's step count (default 2)")
    parser.add_argument("--limit", type=int, default=None,
                        help="run only the first N instances")
    parser.add_argument("--report", type=Path, default=None,
                        help="write per-instance results (success, moves, failures) as JSON")
    remote = parser.add_argument_group(
        "policy server", "the policy runs in another process: nsrmp-bench serve POLICY "
        "(docs/policy-server.md); results are journalled as they come (OUT.journal) and a "
        "rerun of the same command resumes")
    remote.add_argument("--server", default=None, metavar="ws://HOST:PORT",
                        help="drive the policy served at this URL instead of importing it")
    remote.add_argument("--timeout", type=float, default=60.0,
                        help="seconds to wait for each reply before the server counts as "
                             "stalled (default 60)")
    remote.add_argument("--connect-timeout", type=float, default=10.0,
                        help="seconds to wait for the connection (default 10)")
    remote.add_argument("--retries", type=int, default=2,
                        help="reconnections per instance after a dropped connection "
                             "(default 2; the instance reruns from its start)")
    add_engine_arguments(parser, workers=1)
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def run(args: argparse.Namespace) -> int:
    """Roll out, write the predictions and the report."""
    import nsrmp_bench.reference_model.registry  # noqa: F401  (registers the retired ids)
    from nsrmp_bench.predictors import refuse_retired

    if args.server is not None:
        return _run_remote(args)
    if args.policy is None:
        msg = "give a POLICY to run in this process, or --server ws://HOST:PORT"
        raise InvalidArgument(msg)
    refuse_retired(args.policy)  # a retired model is said before gymnasium is needed
    from nsrmp_bench.envs.policies import (
        check_policy,
        policy_predictor,
        reads_boxes,
        reads_gold_boxes,
    )
    from nsrmp_bench.envs.rollout import RolloutConfig, rollout_part

    check_policy(args.policy)
    from nsrmp_bench.envs.policies import EE_POLICIES

    if args.policy in EE_POLICIES and args.control != "ee":
        msg = f"policy {args.policy!r} issues end-effector actions: add --control ee"
        raise InvalidArgument(msg)
    if args.control == "ee" and args.policy not in EE_POLICIES and ":" not in args.policy:
        msg = (f"--control ee needs a policy of end-effector actions ({list(EE_POLICIES)} or "
               f"module:function); {args.policy!r} issues whole moves: drop --control ee")
        raise InvalidArgument(msg)
    if args.control == "ee":
        args.executor = "robot"  # the Panda carries out end-effector actions
    if args.boxes is None and reads_boxes(args.policy):
        args.boxes = "gold"  # these models read boxes; the gold ones unless told
    if reads_gold_boxes(args.policy) and args.boxes != "gold":
        msg = (f"policy {args.policy!r} issues DSL steps over the scene's objects, so it reads "
               f"the gold boxes (scene order); --boxes {args.boxes} gives detections in score "
               "order: drop --boxes, or roll out 'dense' on detected boxes")
        raise InvalidArgument(msg)
    if args.workers < 1:
        msg = f"--workers must be >= 1, got {args.workers}"
        raise InvalidArgument(msg)
    ids, split_id, part = _instances(args)
    config = RolloutConfig(
        policy=args.policy, data=None if args.data is None else str(args.data),
        split=args.split, part=part, executor=args.executor, boxes=args.boxes,
        step_margin=args.step_margin, control=args.control)

    def progress(done: int) -> None:
        if not args.quiet and (done % 10 == 0 or done == len(ids)):
            print(f"  {done}/{len(ids)}", file=sys.stderr)

    with engine_from_args(args) as engine:
        if not args.quiet:
            print(f"rolling out {args.policy} on {len(ids)} instance(s) of {split_id} "
                  f"({args.executor} executor) in {engine.describe()}", file=sys.stderr)
        results = rollout_part(config, ids, engine, tasks=args.workers, progress=progress)
    label = args.policy
    entry = policy_predictor(args.policy)
    if entry is not None and reads_boxes(args.policy):  # a learned model: name its version
        label = entry.id
    _write(args, split_id, args.policy, label, results)
    return 0


def _instances(args: argparse.Namespace) -> tuple[list[str], str, str]:
    """(the instance ids to run, the split id 'name-vN/part', the part)."""
    if args.data is None and args.split is None:
        msg = "give --data (a generated part) or --split (a split id, generated on the fly)"
        raise InvalidArgument(msg)
    if args.limit is not None and args.limit < 0:
        msg = f"--limit must be >= 0, got {args.limit}"
        raise InvalidArgument(msg)
    part = args.part
    split_id: str | None = None
    if args.data is not None:
        from nsrmp_bench.storage import open as open_storage

        with open_storage(args.data, part=part) as collection:
            ids = list(collection.ids)
            split_id = collection.split or None
        if part is None and split_id and "/" in split_id:
            part = split_id.split("/", 1)[1]
    else:
        from nsrmp_bench.split_specs import resolve_split

        spec = resolve_split(args.split)
        part = part or "test"
        ids = [spec.episode_id(part, i) for i in range(spec.part(part).count)]
        split_id = f"{spec.id}/{part}"
    if not split_id:
        msg = f"{args.data} records no split id; it is not a generated part"
        raise InvalidArgument(msg)
    if args.limit is not None:
        ids = ids[:args.limit]
    return ids, split_id, part or "test"


def _write(args: argparse.Namespace, split_id: str, policy: str, label: str,
           results: list[tuple[Any, dict[str, Any]]]) -> None:
    """The predictions file (atomically), the report, the closing line."""
    header = SubmissionHeader(
        split=split_id, model=f"{label} (closed-loop rollout)",
        extra={"rollout": {"env": "nsrmp_bench/Tabletop-v0", "policy": policy,
                           "executor": args.executor, "step_margin": args.step_margin,
                           "boxes": args.boxes,
                           **({"control": "ee"} if args.control == "ee" else {})}})
    write_submission(args.out, header, [p for p, _ in results])
    summaries = [s for _, s in results]
    ok = sum(s["is_success"] for s in summaries)
    if args.report is not None:
        tmp = args.report.with_name(args.report.name + ".tmp")
        tmp.write_text(json.dumps({"instances": summaries}, indent=1) + "\n", "utf-8")
        tmp.replace(args.report)
    if not args.quiet:
        print(f"wrote {args.out}: {len(results)} instance(s), {ok} successful in the "
              "environment", file=sys.stderr)


def _run_remote(args: argparse.Namespace) -> int:
    """``--server``: the policy in the server's process, results journalled as they come."""
    from nsrmp_bench.envs.rollout import RolloutConfig
    from nsrmp_bench.serving.client import PolicyClient, check_url
    from nsrmp_bench.serving.journal import RolloutJournal, journal_path
    from nsrmp_bench.serving.remote_rollout import rollout_remote

    check_url(args.server)
    if args.workers != 1 or args.engine not in (None, "local", "inline"):
        msg = ("--server runs one connection in this process: drop --workers/--engine (run "
               "one rollout per server to spread the load)")
        raise InvalidArgument(msg)
    if args.retries < 0:
        msg = f"--retries must be >= 0, got {args.retries}"
        raise InvalidArgument(msg)
    if args.control == "ee":
        args.executor = "robot"  # the Panda carries out end-effector actions
    ids, split_id, part = _instances(args)
    with PolicyClient(args.server, timeout=args.timeout,
                      connect_timeout=args.connect_timeout, control=args.control) as client:
        hello = client.connect()
        policy = str(hello.get("policy") or hello.get("model_server") or "")
        label = str(hello.get("label") or policy)
        if not policy:
            policy = label = "remote"
        if args.policy is not None and args.policy != policy:
            msg = (f"the server at {args.server} serves policy {policy!r}, not "
                   f"{args.policy!r}: drop POLICY or point --server at the right server")
            raise InvalidArgument(msg)
        if args.boxes is None and isinstance(hello.get("boxes"), str):
            args.boxes = hello["boxes"]  # the boxes the served model reads
        config = RolloutConfig(
            policy=policy, data=None if args.data is None else str(args.data),
            split=args.split, part=part, executor=args.executor, boxes=args.boxes,
            step_margin=args.step_margin, control=args.control)
        run = {"split": split_id, "policy": policy, "executor": args.executor,
               "boxes": args.boxes, "step_margin": args.step_margin,
               "control": args.control, "instances": len(ids),
               "first": ids[0] if ids else None}
        journal = RolloutJournal(journal_path(args.out), run)
        try:
            if not args.quiet:
                kept = sum(i in journal.records for i in ids)
                print(f"rolling out {policy} served at {args.server} on {len(ids)} "
                      f"instance(s) of {split_id} ({args.executor} executor)"
                      + (f"; resuming, {kept} already done" if kept else ""),
                      file=sys.stderr)

            def progress(done: int) -> None:
                if not args.quiet and (done % 10 == 0 or done == len(ids)):
                    print(f"  {done}/{len(ids)}", file=sys.stderr)

            results = rollout_remote(config, ids, client, journal, split=split_id,
                                     retries=args.retries, progress=progress)
        finally:
            journal.close()
    _write(args, split_id, policy, label or policy, results)
    journal.remove()
    return 0
