"""Environment steps per second of ``nsrmp_bench/Tabletop-v0`` on one core.

    python benchmarks/bench_env.py DATA [--part test] [--episodes 16] [--executor teleport]
                                   [--repeat 3]

Runs, in this one process (PyBullet is single-threaded; BLAS and torch threads are pinned
to 1 here), for the first ``--episodes`` instances of the part: ``reset`` by instance,
then the oracle's DSL steps, then ``done``; and separately, random pick-and-place actions
drawn from the action space (seeded) until truncation. Prints the median over
``--repeat`` runs of: milliseconds per ``reset``, milliseconds per moving ``step``, and
environment steps per second counting resets (moves / (reset + move time)). Figures
assume the core is ours alone; another busy process on the machine slows them.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

from nsrmp_bench.envs.tabletop import TabletopEnv  # noqa: E402


def _run(env: TabletopEnv, episodes: int, mode: str, seed: int) -> tuple[float, float, int]:
    """(reset seconds, step seconds, moving steps)."""
    reset_s = step_s = 0.0
    moves = 0
    env.action_space.seed(seed)
    for i in range(episodes):
        t = time.perf_counter()
        env.reset(options={"instance": i})
        reset_s += time.perf_counter() - t
        assert env.episode is not None
        if mode == "oracle":
            actions: list[Any] = [{"step": (s.action, s.subject, s.reference)}
                                  for s in env.episode.symbolic.grounded]
        else:
            actions = []
            for _ in range(env.max_steps):
                a = env.action_space.sample()
                a["done"] = 0
                actions.append(a)
        for a in actions:
            t = time.perf_counter()
            env.step(a)
            step_s += time.perf_counter() - t
            moves += 1
    return reset_s, step_s, moves


def main() -> None:
    """Measure and print."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("data")
    parser.add_argument("--part", default="test")
    parser.add_argument("--episodes", type=int, default=16)
    parser.add_argument("--executor", default="teleport", choices=("teleport", "robot"))
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    env = TabletopEnv(args.data, part=args.part, executor=args.executor)
    n = min(args.episodes, len(env.source.ids))
    try:
        _run(env, 1, "oracle", 0)  # warm-up: builds the world and its asset cache
        for mode in ("oracle", "random"):
            runs = [_run(env, n, mode, k) for k in range(args.repeat)]
            reset_ms = statistics.median(r[0] / n * 1e3 for r in runs)
            step_ms = statistics.median(r[1] / max(r[2], 1) * 1e3 for r in runs)
            sps = statistics.median(r[2] / (r[0] + r[1]) for r in runs)
            moves = runs[0][2]
            print(f"{args.executor} {mode:6s}: {n} episodes, {moves} moves; reset "
                  f"{reset_ms:.1f} ms, step {step_ms:.1f} ms; {1e3 / step_ms:.1f} steps/s "
                  f"(moves only), {sps:.1f} steps/s counting resets")
    finally:
        env.close()


if __name__ == "__main__":
    main()
