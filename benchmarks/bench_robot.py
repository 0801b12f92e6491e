"""Throughput and success of the Panda pick-and-place controller, on all cores.

``--processes`` spawned workers (one PyBullet World each) sample their share of generated
episodes (1-3 steps, 3-15 objects, relational mixed; seeds ``SeedSequence(entropy, (i,
attempt))``, outside the timed span), wait on a barrier, then for each episode put the
initial scene in place and let the robot carry out the grounded program (``--render``:
also render the initial state and the state after every step, as robot-executed data
generation would). The timed loop gives **pick-and-places per second** and **robot
episodes per second** over all workers. Afterwards (untimed) every step's success, its
error to the symbolic target, how far it pushed other objects, and the robot-vs-teleport
final-pose difference (the same episode realised by teleport-and-settle) are gathered.

The machine's other load during the timed span is measured (busy CPU from /proc/stat
minus our own processes' CPU) and printed: runs with foreign load are not comparable.

Examples::

    .venv/bin/python benchmarks/bench_robot.py                          # the report's figures
    .venv/bin/python benchmarks/bench_robot.py --episodes 20 --processes 1
    .venv/bin/python benchmarks/bench_robot.py --profile realistic --episodes 20
    .venv/bin/python benchmarks/bench_robot.py --render --json robot_bench.json
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import threading
import time
from dataclasses import asdict, dataclass, field
from typing import Any

ENTROPY = 20261124


@dataclass
class WorkerResult:
    """What one worker measured."""

    episodes: int = 0
    steps: int = 0
    wall: float = 0.0
    cpu: float = 0.0
    render_time: float = 0.0
    sim_time: float = 0.0
    physics_steps: int = 0
    records: list[dict[str, Any]] = field(default_factory=list)
    teleport_diff_moved: list[float] = field(default_factory=list)
    teleport_diff_other: list[float] = field(default_factory=list)
    teleport_rejected: int = 0
    episode_walls: list[tuple[int, float]] = field(default_factory=list)  # (steps, s)


def _episodes(worker: int, count: int, workers: int, entropy: int) -> list[Any]:
    from nsrmp_bench.config import EpisodeConfig
    from nsrmp_bench.generators.sampler import sample_episode

    out = []
    for k in range(count):
        i = k * workers + worker  # interleaved: every worker gets a similar mix
        config = EpisodeConfig(objects=3 + (i * 7) % 13, steps=1 + i % 3,
                               relational=("none", "any", "needed")[i % 3])
        out.append(sample_episode(config, entropy, i, f"bench/{i:06d}"))
    return out


def _cpu_busy() -> float:
    """Busy CPU seconds of the whole machine so far (user+nice+system+irq+softirq)."""
    with open("/proc/stat") as fh:
        fields = fh.readline().split()[1:]
    ticks = [int(v) for v in fields]
    busy = ticks[0] + ticks[1] + ticks[2] + ticks[5] + ticks[6]
    return busy / os.sysconf("SC_CLK_TCK")


def _worker(worker: int, workers: int, count: int, profile: str, render: bool,
            teleport: bool, entropy: int, barrier: Any, queue: Any) -> None:
    try:
        _work(worker, workers, count, profile, render, teleport, entropy, barrier, queue)
    except BaseException as exc:  # tell the parent instead of leaving it at the barrier
        barrier.abort()
        queue.put((worker, {"error": f"{type(exc).__name__}: {exc}"}))
        raise


def _work(worker: int, workers: int, count: int, profile: str, render: bool,
          teleport: bool, entropy: int, barrier: Any, queue: Any) -> None:
    from nsrmp_bench.generators.replay.episode import stage_scene
    from nsrmp_bench.generators.robot.pick_and_place import execute_program
    from nsrmp_bench.generators.world.world import World

    episodes = _episodes(worker, count, workers, entropy)
    result = WorkerResult()
    with World() as world:
        # warm-up (not timed): one step, so caches and kinematics are built
        warm = episodes[0]
        stage_scene(world, warm.scene)
        execute_program(world, warm.scene, warm.states[:2], warm.grounded[:1], profile)
        barrier.wait()
        t0, c0 = time.perf_counter(), time.process_time()
        programs = []
        for ep in episodes:
            e0 = time.perf_counter()
            stage_scene(world, ep.scene)
            if render:
                r0 = time.perf_counter()
                world.render()
                result.render_time += time.perf_counter() - r0

            def on_step(k: int, step: Any) -> None:
                if render:
                    r0 = time.perf_counter()
                    world.render()
                    result.render_time += time.perf_counter() - r0

            programs.append(execute_program(world, ep.scene, ep.states, ep.grounded, profile,
                                            on_step=on_step))
            result.episode_walls.append((len(ep.grounded), time.perf_counter() - e0))
        result.wall = time.perf_counter() - t0
        result.cpu = time.process_time() - c0
        # untimed: what each step did, and the teleported result for comparison
        import numpy as np

        from nsrmp_bench.errors import GenerationError
        from nsrmp_bench.generators.world.realise import realise

        for ep, prog in zip(episodes, programs, strict=True):
            result.episodes += 1
            result.steps += len(prog.steps)
            result.sim_time += prog.physics["sim_time"]
            result.physics_steps += prog.physics["physics_steps"]
            for s in prog.steps:
                result.records.append({"episode": ep.id, "objects": len(ep.scene),
                                       "shape": ep.scene.objects[s.subject].shape,
                                       **s.to_dict()})
            if teleport:
                try:
                    tele = realise(ep.scene, ep.states, ep.grounded, world, render=False)
                except GenerationError:
                    result.teleport_rejected += 1
                    continue
                diff = np.linalg.norm(prog.final_poses[:, :3]
                                      - tele.targets.poses[-1][:, :3], axis=1)
                moved = sorted({g.subject for g in ep.grounded})
                result.teleport_diff_moved += [float(diff[i]) for i in moved]
                result.teleport_diff_other += [float(d) for i, d in enumerate(diff)
                                               if i not in moved]
    queue.put((worker, asdict(result)))


def _pct(values: list[float], q: float) -> float:
    import numpy as np

    return float(np.percentile(values, q)) if values else float("nan")


def wait_quiet(limit_s: float, threshold: float = 0.15, window: float = 3.0) -> float:
    """Wait (up to ``limit_s``) until the machine's busy CPU over ``window`` seconds is
    below ``threshold`` cores; returns the last measured load in cores."""
    deadline = time.monotonic() + limit_s
    while True:
        b0 = _cpu_busy()
        time.sleep(window)
        load = (_cpu_busy() - b0) / window
        if load < threshold or time.monotonic() > deadline:
            return load


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Run the workers, gather and summarise."""
    quiet = wait_quiet(args.wait_quiet) if args.wait_quiet > 0 else None
    ctx = mp.get_context("spawn")
    barrier = ctx.Barrier(args.processes + 1)
    queue = ctx.Queue()
    per = max(1, args.episodes // args.processes)
    procs = [ctx.Process(target=_worker, args=(w, args.processes, per, args.profile,
                                               args.render, not args.no_teleport,
                                               args.entropy, barrier, queue))
             for w in range(args.processes)]
    for p in procs:
        p.start()
    try:
        barrier.wait()
    except threading.BrokenBarrierError:
        _, res = queue.get(timeout=60)
        for p in procs:
            p.join()
        msg = f"a worker failed before the timed span: {res.get('error')}"
        raise SystemExit(msg) from None
    busy0, t0 = _cpu_busy(), time.perf_counter()
    results: dict[int, dict[str, Any]] = {}
    while len(results) < args.processes:
        w, res = queue.get()
        if "error" in res:
            msg = f"worker {w} failed: {res['error']}"
            raise SystemExit(msg)
        results[w] = res
    for p in procs:
        p.join()
    # the timed span is the slowest worker's; foreign load is measured over it
    span = max(r["wall"] for r in results.values())
    busy = _cpu_busy() - busy0
    ours = sum(r["cpu"] for r in results.values())
    elapsed = time.perf_counter() - t0
    records = [rec for r in results.values() for rec in r["records"]]
    steps = len(records)
    episodes = sum(r["episodes"] for r in results.values())
    ok = sum(1 for rec in records if rec["success"])
    errors = [rec["error_m"] for rec in records]
    sym = [rec["symbolic_error_m"] for rec in records if rec["symbolic_error_m"] is not None]
    disturbed = [rec["disturbed_m"] for rec in records]
    problems: dict[str, int] = {}
    for rec in records:
        if rec["problem"]:
            problems[rec["problem"]] = problems.get(rec["problem"], 0) + 1
    moved = [d for r in results.values() for d in r["teleport_diff_moved"]]
    other = [d for r in results.values() for d in r["teleport_diff_other"]]
    by_steps: dict[str, float] = {}
    walls = [tuple(x) for r in results.values() for x in r["episode_walls"]]
    for k in sorted({int(n) for n, _ in walls}):
        mean = sum(w for n, w in walls if n == k) / sum(1 for n, _ in walls if n == k)
        by_steps[f"{k}-step"] = args.processes / mean  # all workers running such episodes
    summary = {
        "profile": args.profile,
        "entropy": args.entropy,
        "processes": args.processes,
        "render": args.render,
        "episodes": episodes,
        "steps": steps,
        "wall_s": span,
        "pick_and_places_per_s": steps / span,
        "episodes_per_s": episodes / span,
        "episodes_per_s_by_steps": by_steps,
        "cpu_s_per_pick_and_place": ours / steps,
        "sim_s_per_pick_and_place": sum(r["sim_time"] for r in results.values()) / steps,
        "physics_steps_per_pick_and_place":
            sum(r["physics_steps"] for r in results.values()) / steps,
        "render_s_per_episode": sum(r["render_time"] for r in results.values()) / episodes,
        "success_rate": ok / steps,
        "successes": ok,
        "problems": problems,
        "error_mm_median_p95_max": [1000 * _pct(errors, 50), 1000 * _pct(errors, 95),
                                    1000 * max(errors)],
        "symbolic_error_mm_median_p95_max": [1000 * _pct(sym, 50), 1000 * _pct(sym, 95),
                                             1000 * max(sym)] if sym else None,
        "disturbed_mm_p95_max": [1000 * _pct(disturbed, 95), 1000 * max(disturbed)],
        "robot_vs_teleport_mm": {
            "moved_median_p95_max": [1000 * _pct(moved, 50), 1000 * _pct(moved, 95),
                                     1000 * max(moved)] if moved else None,
            "others_p95_max": [1000 * _pct(other, 95), 1000 * max(other)] if other else None,
            "teleport_rejected": sum(r["teleport_rejected"] for r in results.values()),
        },
        "foreign_cpu_s": max(0.0, busy - ours - 0.0),
        "foreign_cpu_fraction_of_span": max(0.0, busy - ours) / max(elapsed, 1e-9),
        "load_before_start_cores": quiet,
        "loadavg_after": os.getloadavg(),
    }
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"summary": summary, "steps": records}, fh, indent=1)
    return summary


def main() -> None:
    """Command line."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--processes", type=int, default=2)
    parser.add_argument("--episodes", type=int, default=120,
                        help="episodes in all (default 120: ~240 pick-and-places)")
    parser.add_argument("--profile", default="fast", choices=("fast", "realistic"))
    parser.add_argument("--render", action="store_true",
                        help="also render the initial state and every step's result")
    parser.add_argument("--no-teleport", action="store_true",
                        help="skip the robot-vs-teleport comparison")
    parser.add_argument("--json", default=None, help="write the summary and every step here")
    parser.add_argument("--entropy", type=int, default=ENTROPY,
                        help=f"seed entropy of the episodes (default {ENTROPY})")
    parser.add_argument("--wait-quiet", type=float, default=0.0, metavar="S",
                        help="first wait up to S seconds for the machine to be idle")
    args = parser.parse_args()
    summary = run(args)
    width = max(len(k) for k in summary)
    for key, value in summary.items():
        if isinstance(value, float):
            value = f"{value:.4g}"
        elif isinstance(value, list):
            value = ", ".join(f"{v:.3g}" for v in value)
        print(f"{key:<{width}}  {value}")


if __name__ == "__main__":
    main()
