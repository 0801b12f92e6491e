"""Throughput of the PyBullet world: rendered episodes per second against the render bound.

For each configuration, ``--processes`` spawned workers (one World each) sample their
share of symbolic episodes with the project's sampler (seeds ``SeedSequence(entropy,
(i, attempt))``, symbolic rejections move to the next attempt, outside the timed span),
wait on a barrier, then realise them (place, settle, check, render every state, measure
the targets): that timed loop gives **episodes/s**. Each worker then re-renders the very
states it accepted, from the settled poses, with nothing else going on: renders x
per-image time is the **render-only bound**, and episodes/s over the bound's episodes/s
is the **ratio** (1.0 would mean physics, checks and targets cost nothing).

The machine's other load is measured during every run (busy CPU from /proc/stat minus
our own processes) and printed: runs with foreign load are not comparable.

Examples::

    .venv/bin/python benchmarks/bench_render.py                       # the report's table
    .venv/bin/python benchmarks/bench_render.py --quick               # a smoke run
    .venv/bin/python benchmarks/bench_render.py --configs 320x240:1:3-5 1024x768:1:3-5:hires
    .venv/bin/python benchmarks/bench_render.py --rejections 400      # rejection rates only
"""

from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing as mp
import os
import time
from collections import Counter
from dataclasses import asdict, dataclass, field
from typing import Any

ENTROPY = 20261123


@dataclass
class Config:
    """One measured configuration."""

    width: int
    height: int
    steps: int
    objects_lo: int
    objects_hi: int
    episodes: int  # per worker
    label: str = ""
    composite: bool = True

    @classmethod
    def parse(cls, text: str, episodes: int) -> Config:
        """``WxH:STEPS:LO-HI[:label]``."""
        parts = text.split(":")
        w, h = (int(v) for v in parts[0].lower().split("x"))
        lo, _, hi = parts[2].partition("-")
        return cls(w, h, int(parts[1]), int(lo), int(hi or lo), episodes,
                   parts[3] if len(parts) > 3 else "")


@dataclass
class WorkerResult:
    """What one worker measured."""

    accepted: int = 0
    attempts: int = 0
    rejections: dict[str, int] = field(default_factory=dict)
    wall: float = 0.0
    cpu: float = 0.0
    renders: int = 0
    render_in_run: float = 0.0
    bound_renders: int = 0
    bound_time: float = 0.0
    bound_cpu: float = 0.0
    settle_steps: int = 0


def _symbolic(config: Config, worker: int, count: int) -> list[Any]:
    from nsrmp_bench.config import EpisodeConfig
    from nsrmp_bench.episode import SeedInfo
    from nsrmp_bench.errors import GenerationError
    from nsrmp_bench.generators.sampler import sample_symbolic

    out = []
    index = worker * 1_000_000
    while len(out) < count:
        n = config.objects_lo + index % (config.objects_hi - config.objects_lo + 1)
        cfg = EpisodeConfig(objects=n, steps=config.steps)
        for attempt in range(64):
            try:
                out.append(sample_symbolic(cfg, SeedInfo(ENTROPY, index, attempt), f"b{index}"))
                break
            except GenerationError:
                continue
        index += 1
    return out


def _worker(config: Config, worker: int, barrier: Any, queue: Any) -> None:
    import numpy as np

    from nsrmp_bench.generators.world.realise import PhysicsRejection, realise
    from nsrmp_bench.generators.world.world import World
    from nsrmp_bench.geometry.default_camera import official_camera

    world = World(official_camera(config.width, config.height))
    episodes = _symbolic(config, worker, config.episodes)
    res = WorkerResult()
    render = world.render

    def timed_render(*args: Any, **kwargs: Any) -> Any:
        t = time.process_time()
        out = render(*args, **kwargs)
        res.render_in_run += time.process_time() - t
        res.renders += 1
        return out

    world.render = timed_render  # type: ignore[method-assign]
    # warm-up (not timed): first renders and settles pay one-off costs
    for ep in episodes[:2]:
        with contextlib.suppress(PhysicsRejection):
            realise(ep.scene, ep.states, ep.grounded, world, composite=config.composite)
    res.renders = 0
    res.render_in_run = 0.0
    accepted: list[tuple[Any, Any]] = []
    rejections: Counter[str] = Counter()
    barrier.wait()
    c0 = time.process_time()
    t0 = time.perf_counter()
    for ep in episodes:
        res.attempts += 1
        try:
            r = realise(ep.scene, ep.states, ep.grounded, world, composite=config.composite)
        except PhysicsRejection as exc:
            rejections[exc.reason] += 1
            continue
        accepted.append((ep, r))
        res.settle_steps += int(r.physics["total_steps"])
    res.wall = time.perf_counter() - t0
    res.cpu = time.process_time() - c0
    res.accepted = len(accepted)
    res.rejections = dict(rejections)
    world.render = render  # type: ignore[method-assign]
    barrier.wait()
    # the render-only bound: the same states, rendered from their settled poses
    from nsrmp_bench.scene import Pose

    t_render = 0.0
    c_render = 0.0
    for ep, r in accepted:
        world.begin(ep.scene.objects)
        world.prepare_background()
        for k in range(r.targets.poses.shape[0]):
            for i, row in enumerate(np.asarray(r.targets.poses[k])):
                world.place(i, Pose(tuple(row[:3]), tuple(row[3:])))
            t, c = time.perf_counter(), time.process_time()
            world.render(composite=config.composite)
            t_render += time.perf_counter() - t
            c_render += time.process_time() - c
            res.bound_renders += 1
    res.bound_time = t_render
    res.bound_cpu = c_render
    world.close()
    queue.put((worker, asdict(res)))


def _busy_jiffies() -> tuple[int, int]:
    with open("/proc/stat") as fh:
        parts = [int(v) for v in fh.readline().split()[1:]]
    busy = parts[0] + parts[1] + parts[2] + parts[5] + parts[6]
    return busy, sum(parts)


def wait_quiet(limit: float = 0.1, window: float = 3.0, timeout: float = 300.0) -> float:
    """Wait until the machine's busy CPU stays below ``limit`` cores for ``window`` s
    (at most ``timeout`` s); returns the seconds waited."""
    ticks = os.sysconf("SC_CLK_TCK")
    start = time.perf_counter()
    while time.perf_counter() - start < timeout:
        b0, _ = _busy_jiffies()
        time.sleep(window)
        b1, _ = _busy_jiffies()
        if (b1 - b0) / ticks / window < limit:
            break
    return time.perf_counter() - start


def run_config(config: Config, processes: int) -> dict[str, Any]:
    """Run one configuration in ``processes`` workers and summarise it."""
    ctx = mp.get_context("spawn")
    barrier = ctx.Barrier(processes + 1)
    queue = ctx.Queue()
    procs = [ctx.Process(target=_worker, args=(config, w, barrier, queue))
             for w in range(processes)]
    for p in procs:
        p.start()
    barrier.wait()  # all workers built their world and sampled their episodes
    ticks = os.sysconf("SC_CLK_TCK")
    b0, _ = _busy_jiffies()
    t0 = time.perf_counter()
    barrier.wait()  # all workers finished the timed loop
    wall = time.perf_counter() - t0
    b1, _ = _busy_jiffies()
    results = [queue.get() for _ in procs]
    for p in procs:
        p.join()
    workers = [WorkerResult(**r) for _, r in sorted(results)]
    own_cpu = sum(w.cpu for w in workers)
    busy = (b1 - b0) / ticks
    accepted = sum(w.accepted for w in workers)
    attempts = sum(w.attempts for w in workers)
    rejections: Counter[str] = Counter()
    for w in workers:
        rejections.update(w.rejections)
    # bound: each worker's accepted episodes over its pure render time, summed (parallel)
    bound_eps = sum(w.accepted / w.bound_time for w in workers if w.bound_time > 0)
    per_image_ms = 1000 * sum(w.bound_time for w in workers) / max(
        1, sum(w.bound_renders for w in workers))
    eps = accepted / wall
    # the same ratio from CPU time, robust to other load on the machine: CPU the renders
    # of the accepted episodes need, over CPU the whole loop took
    bound_cpu = sum(w.bound_cpu for w in workers)
    return {
        "ratio_cpu": bound_cpu / own_cpu if own_cpu else float("nan"),
        "config": asdict(config),
        "processes": processes,
        "episodes_per_s": eps,
        "render_bound_episodes_per_s": bound_eps,
        "ratio": eps / bound_eps if bound_eps else float("nan"),
        "per_image_ms": per_image_ms,
        "renders_per_episode": sum(w.renders for w in workers) / max(1, attempts),
        "render_share_in_run": sum(w.render_in_run for w in workers) / max(1e-9, own_cpu),
        "cpu_ms_per_episode": 1000 * own_cpu / max(1, attempts),
        "settle_steps_per_episode": sum(w.settle_steps for w in workers) / max(1, accepted),
        "accepted": accepted,
        "attempts": attempts,
        "rejections": dict(rejections),
        "wall_s": wall,
        "foreign_cpu_s": max(0.0, busy - own_cpu),
    }


def rejection_rates(objects: tuple[int, int], steps: tuple[int, int], count: int,
                    width: int = 320, height: int = 240) -> dict[str, Any]:
    """Attempts and physics rejections by reason, in this process (not timed)."""
    from nsrmp_bench.config import EpisodeConfig
    from nsrmp_bench.episode import SeedInfo
    from nsrmp_bench.errors import GenerationError
    from nsrmp_bench.generators.sampler import sample_symbolic
    from nsrmp_bench.generators.world.realise import PhysicsRejection, realise
    from nsrmp_bench.generators.world.world import World
    from nsrmp_bench.geometry.default_camera import official_camera

    world = World(official_camera(width, height))
    reasons: Counter[str] = Counter()
    physical = symbolic = 0
    low_vis: list[float] = []
    drift: list[float] = []
    for i in range(count):
        n = objects[0] + i % (objects[1] - objects[0] + 1)
        s = steps[0] + (i // 7) % (steps[1] - steps[0] + 1)
        try:
            ep = sample_symbolic(EpisodeConfig(objects=n, steps=s), SeedInfo(ENTROPY + 1, i, 0),
                                 f"r{i}")
        except GenerationError:
            symbolic += 1
            continue
        physical += 1
        try:
            r = realise(ep.scene, ep.states, ep.grounded, world)
        except PhysicsRejection as exc:
            reasons[exc.reason] += 1
            continue
        low_vis.append(min(r.physics["min_visible_fraction"]))
        drift.append(max(r.physics["max_drift_m"]))
    world.close()
    import numpy as np
    return {
        "objects": list(objects), "steps": list(steps), "symbolic_attempts": count,
        "symbolic_rejections": symbolic, "physical_attempts": physical,
        "physics_rejections": dict(reasons),
        "physics_rejection_rate": sum(reasons.values()) / max(1, physical),
        "exposed_fraction_p1": float(np.percentile(low_vis, 1)) if low_vis else None,
        "exposed_fraction_min": min(low_vis, default=None),
        "drift_mm_p99": 1000 * float(np.percentile(drift, 99)) if drift else None,
    }


def breakdown(sizes: list[tuple[int, int]], repeats: int = 15) -> list[dict[str, Any]]:
    """Median CPU ms per render of scene variants (what a render's time is made of)."""
    import numpy as np

    from nsrmp_bench.generators.world.world import World, WorldConfig
    from nsrmp_bench.geometry.default_camera import official_camera
    from nsrmp_bench.scene import Pose, SceneObject, yaw_quaternion
    from nsrmp_bench.vocabulary import COLOURS, EXTENTS, SHAPES, TABLE_TOP_Z

    rng = np.random.default_rng(0)
    objects = [SceneObject(SHAPES[i % 3], COLOURS[i % 7]) for i in range(15)]
    poses = [Pose(((i % 5 - 2) * 0.14, (i // 5 - 1) * 0.14,
                   TABLE_TOP_Z + EXTENTS[o.shape][2] / 2), yaw_quaternion(rng.uniform(0, 3)))
             for i, o in enumerate(objects)]
    variants = [
        ("table only", WorldConfig(panda="none"), 0, True),
        ("table + 15 objects", WorldConfig(panda="none"), 15, True),
        ("table + lean Panda + 15 objects (official)", WorldConfig(), 15, True),
        ("table + stock Panda + 15 objects", WorldConfig(panda="stock"), 15, True),
        ("floor + table + lean Panda + 15 objects", WorldConfig(floor=True), 15, True),
        ("floor + table + stock Panda + 15 objects", WorldConfig(panda="stock", floor=True),
         15, True),
        ("lean Panda + 15 objects, no table", WorldConfig(), 15, False),
    ]
    out = []
    for name, cfg, n, table in variants:
        world = World(config=cfg)
        world.begin(objects[:n])
        for i in range(n):
            world.place(i, poses[i])
        if not table:
            world.pb.removeBody(world.table, physicsClientId=world.client)
        row: dict[str, Any] = {"variant": name}
        for w, h in sizes:
            cam = official_camera(w, h)
            world.render(cam)
            times = []
            for _ in range(repeats if w <= 640 else max(3, repeats // 3)):
                c = time.process_time()
                world.render(cam)
                times.append(time.process_time() - c)
            row[f"{w}x{h}"] = 1000 * float(np.median(times))
        world.close()
        out.append(row)
        print(f"{name:45s} " + "  ".join(f"{k}: {v:6.1f} ms" for k, v in row.items()
                                            if k != "variant"), flush=True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--processes", type=int, default=2)
    parser.add_argument("--episodes", type=int, default=60, help="episodes per worker")
    parser.add_argument("--configs", nargs="*", default=[
        "320x240:1:3-5", "320x240:5:3-5", "320x240:1:15", "320x240:5:15",
        "1024x768:1:3-5:hires"])
    parser.add_argument("--full-render", action="store_true",
                        help="render every image in full (no cached empty scene)")
    parser.add_argument("--single", action="store_true",
                        help="also run every config in one process")
    parser.add_argument("--rejections", type=int, default=300,
                        help="attempts per object range for the rejection rates (0: skip)")
    parser.add_argument("--quick", action="store_true", help="few episodes, no rejections")
    parser.add_argument("--breakdown", action="store_true",
                        help="only time renders of scene variants (table, Panda, floor)")
    parser.add_argument("--json", help="write all results to this JSON file")
    parser.add_argument("--wait-quiet", action="store_true",
                        help="before each run wait (<= 5 min) until other load is < 0.1 core")
    parser.add_argument("--tries", type=int, default=1,
                        help="repeat a run until its foreign CPU is < 5%% of its wall time")
    args = parser.parse_args()
    if args.quick:
        args.episodes, args.rejections = 8, 0
    if args.breakdown:
        rows = breakdown([(320, 240), (1024, 768)])
        if args.json:
            with open(args.json, "w") as fh:
                json.dump({"breakdown": rows}, fh, indent=1)
        return
    results: list[dict[str, Any]] = []
    for text in args.configs:
        per = args.episodes if "1024" not in text else max(4, args.episodes // 3)
        cfg = Config.parse(text, per)
        cfg.composite = not args.full_render
        for procs in ([1, args.processes] if args.single else [args.processes]):
            for _ in range(args.tries):
                waited = wait_quiet() if args.wait_quiet else 0.0
                r = run_config(cfg, procs)
                r["waited_s"] = waited
                if r["foreign_cpu_s"] <= 0.05 * r["wall_s"] + 0.1:
                    break
            results.append(r)
            c = r["config"]
            print(
                f"{'full' if not c['composite'] else 'composite'} "
                f"{c['width']}x{c['height']} steps={c['steps']} objects={c['objects_lo']}-"
                f"{c['objects_hi']} procs={procs}: {r['episodes_per_s']:.2f} ep/s, render "
                f"bound {r['render_bound_episodes_per_s']:.2f} ep/s, ratio {r['ratio']:.3f} "
                f"(CPU-time ratio {r['ratio_cpu']:.3f}); "
                f"{r['per_image_ms']:.1f} ms/image, {r['cpu_ms_per_episode']:.1f} CPU-ms/ep "
                f"({100 * r['render_share_in_run']:.0f}% rendering), "
                f"{r['settle_steps_per_episode']:.0f} physics steps/ep; {r['accepted']}/"
                f"{r['attempts']} accepted {r['rejections'] or ''}; foreign CPU "
                f"{r['foreign_cpu_s']:.1f} s over {r['wall_s']:.1f} s", flush=True)
    rates = []
    if args.rejections:
        for objects in ((3, 5), (15, 15)):
            rr = rejection_rates(objects, (1, 5), args.rejections)
            rates.append(rr)
            print(f"rejections, objects {objects[0]}-{objects[1]}, steps 1-5: "
                  f"{rr['physics_rejections']} of {rr['physical_attempts']} physical attempts "
                  f"({100 * rr['physics_rejection_rate']:.1f}%); symbolic rejections "
                  f"{rr['symbolic_rejections']}/{rr['symbolic_attempts']}; smallest exposed "
                  f"fraction per episode: 1st percentile {rr['exposed_fraction_p1']:.2f}, min "
                  f"{rr['exposed_fraction_min']:.2f}; drift p99 {rr['drift_mm_p99']:.3f} mm",
                  flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"throughput": results, "rejections": rates}, fh, indent=1)


if __name__ == "__main__":
    main()
