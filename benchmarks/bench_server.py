"""The policy server's overhead per step against the same policy in process.

    python benchmarks/bench_server.py DATA [--part test] [--episodes 16] [--repeat 3]
                                      [--policy oracle] [--observation-keys all|declared]

Runs the first ``--episodes`` instances of the part twice per repeat, alternating: the
policy in this process (``rollout POLICY``'s loop), and the same policy served by
``nsrmp-bench serve POLICY --data DATA`` in a child process on 127.0.0.1 (``rollout
--server``'s loop: one ``observation``/``action`` round trip per step). Times the loop
only (the environment's resets and steps and the policy's calls, not the server's start).
``--observation-keys all`` (the default) sends the full observation, images included,
whatever the policy reads; ``declared`` what the served policy declares it reads (the
oracle: the instruction alone). Prints per repeat and as the median: ms per environment
step in process and through the server, and the overhead in per cent ((server - in
process) / in process), in wall time (as a user sees it; on a loaded machine each of the
three hand-offs per step between the processes waits for a core) and in CPU time (the
rollout's process plus the server's, from /proc: the work the protocol adds).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

from nsrmp_bench.envs.policies import make_policy  # noqa: E402
from nsrmp_bench.envs.rollout import run_episode  # noqa: E402
from nsrmp_bench.envs.tabletop import TabletopEnv  # noqa: E402
from nsrmp_bench.serving.client import PolicyClient  # noqa: E402
from nsrmp_bench.serving.remote_rollout import RemotePolicy  # noqa: E402


def _cpu(pid: int) -> float:
    """CPU seconds (user + system) the process ``pid`` has used (Linux's /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _loop(env: TabletopEnv, policy: Any, episodes: int, client: PolicyClient | None,
          server: int | None = None) -> tuple[float, float, int]:
    """(wall seconds, CPU seconds of this process and the server's, environment steps)."""
    steps = 0
    t, c = time.perf_counter(), time.process_time()
    c_server = _cpu(server) if server else 0.0
    for i in range(episodes):
        _, summary = run_episode(env, policy, i)
        if client is not None:
            client.end_episode({"instance": summary["id"]})
        steps += summary["moves"] + (0 if summary["truncated"] else 1)  # the done step
    cpu = time.process_time() - c + ((_cpu(server) - c_server) if server else 0.0)
    return time.perf_counter() - t, cpu, steps


def _server(policy: str, data: str, part: str | None, keys: str
            ) -> tuple[subprocess.Popen[str], str]:
    code = "from nsrmp_bench.cli.main import main; raise SystemExit(main())"
    args = [sys.executable, "-c", code, "serve", policy, "--data", data, "--port", "0"]
    if keys != "declared":
        args += ["--observation-keys", keys]
    if part:
        args += ["--part", part]
    proc = subprocess.Popen(args, stderr=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    for line in proc.stderr:
        if " on ws://" in line:
            return proc, line.rsplit(" on ", 1)[1].strip()
    msg = f"the server exited {proc.wait()} before listening"
    raise SystemExit(msg)


def main() -> None:
    """Measure and print."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("data")
    parser.add_argument("--part", default=None)
    parser.add_argument("--episodes", type=int, default=16)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--policy", default="oracle")
    parser.add_argument("--observation-keys", default="all",
                        help="what the server asks for: all (the full observation, images "
                             "included: default), declared (what the policy declares: the "
                             "oracle the instruction alone) or KEY,...")
    args = parser.parse_args()
    env = TabletopEnv(args.data, part=args.part or "test")
    local = make_policy(args.policy, env)
    proc, url = _server(args.policy, args.data, args.part, args.observation_keys)
    try:
        with PolicyClient(url, timeout=60) as client:
            client.connect()
            remote = RemotePolicy(client, env, "bench")
            _loop(env, local, 1, None)  # warm both ends up
            _loop(env, remote, 1, client)
            rows = []
            for r in range(args.repeat):
                t_local, c_local, n_local = _loop(env, local, args.episodes, None)
                t_remote, c_remote, n_remote = _loop(env, remote, args.episodes, client,
                                                     proc.pid)
                assert n_local == n_remote
                ms_l, ms_r = 1000 * t_local / n_local, 1000 * t_remote / n_remote
                cpu_l, cpu_r = 1000 * c_local / n_local, 1000 * c_remote / n_remote
                rows.append((ms_l, ms_r, 100 * (ms_r - ms_l) / ms_l, cpu_l, cpu_r,
                             100 * (cpu_r - cpu_l) / cpu_l))
                print(f"repeat {r + 1}: {n_local} steps; wall ms/step in process {ms_l:.2f}, "
                      f"through the server {ms_r:.2f} ({rows[-1][2]:+.1f}%); CPU ms/step "
                      f"{cpu_l:.2f} against {cpu_r:.2f} both processes ({rows[-1][5]:+.1f}%)",
                      flush=True)
    finally:
        proc.kill()
        proc.wait()
        env.close()
    med = [statistics.median(c) for c in zip(*rows, strict=True)]
    print(f"median: wall ms/step in process {med[0]:.2f}, through the server {med[1]:.2f}, "
          f"overhead {med[2]:+.1f}%; CPU ms/step {med[3]:.2f} against {med[4]:.2f}, "
          f"overhead {med[5]:+.1f}% ({args.policy}, observation keys "
          f"{args.observation_keys}, {args.episodes} episodes, "
          f"{args.repeat} repeats; load average {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
