"""End-effector control (``control="ee"``): control steps per second with rendering, on
one core, and the scripted ``oracle-ee``'s success.

    taskset -c 0 python benchmarks/bench_ee.py (--data DATA | --split paper-v2) [--part test]
                                               [--start 0] [--limit N] [--repeat 1]

Runs ``oracle-ee`` on ``--limit`` instances of the part from ``--start`` (a generated part
with ``--data``; with ``--split`` each instance is generated on the fly, which adds to the
reset time only) in this one process, BLAS threads pinned to 1. Each control step is one
``env.step``: 0.1 s of simulated time (24 physics steps of the Panda, inverse kinematics
every 4), the settled scene's measurement and a full 320x240 render with the arm in view.
Prints per repeat: control steps per second counting only the steps (the policy
included; in wall time, and in this process's CPU time, which is what a core of its own
would give where other processes share it), the same counting resets, ms per reset, and
the success (the scorer's: every moved object's box IoU >= 0.5 with gold) with the number
of instances truncated.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402

from nsrmp_bench.envs.policies import make_policy  # noqa: E402
from nsrmp_bench.envs.tabletop import TabletopEnv  # noqa: E402


def main() -> None:
    """Measure and print."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument("--data")
    src.add_argument("--split")
    parser.add_argument("--part", default="test")
    parser.add_argument("--limit", type=int, default=16)
    parser.add_argument("--start", type=int, default=0,
                        help="the first instance (position in the part) to run")
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    env = TabletopEnv(args.data, split=args.split, part=args.part, control="ee")
    policy = make_policy("oracle-ee", env)
    first = max(0, args.start)
    n = max(0, min(args.limit, len(env.source.ids) - first))
    for r in range(args.repeat):
        reset_s = step_s = step_cpu = 0.0
        steps = ok = cut = 0
        for i in range(n):
            t = time.perf_counter()
            obs, info = env.reset(options={"instance": first + i})
            policy.reset(obs, info)  # type: ignore[attr-defined]
            reset_s += time.perf_counter() - t
            while True:
                t, c = time.perf_counter(), time.process_time()
                obs, _, terminated, truncated, info = env.step(policy(obs))
                step_s += time.perf_counter() - t
                step_cpu += time.process_time() - c
                steps += 1
                if terminated or truncated:
                    break
            ok += bool(info["is_success"])
            cut += bool(truncated)
        print(f"repeat {r + 1}: {n} instances from {first}, {steps} control steps; "
              f"{steps / step_s:.1f} control steps/s ({1000 * step_s / steps:.1f} ms each; "
              f"CPU {1000 * step_cpu / steps:.1f} ms each = {steps / step_cpu:.1f}/s of a "
              f"whole core), "
              f"{steps / (step_s + reset_s):.1f}/s counting resets "
              f"({1000 * reset_s / n:.0f} ms per reset); success {ok}/{n} = {ok / n:.3f}, "
              f"{cut} truncated (load average {os.getloadavg()[0]:.1f})", flush=True)
    env.close()


if __name__ == "__main__":
    main()
