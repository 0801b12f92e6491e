"""Dask against the local pool: generation rate, scheduler overhead per task, a projection.

    python benchmarks/bench_dask.py [--split paper-v2] [--part test] [--limit 300]
                                    [--workers 2] [--shard-size 25] [--empty-tasks 200]
                                    [--repeat 2]

Prints, in one run on the local machine:

* episodes per second of ``generate_part`` for the first ``--limit`` instances with the
  local pool (``--engine local``: spawned processes, started by the call) and with a Dask
  LocalCluster of as many single-threaded workers (``--engine dask``, started before the
  call; its start-up is printed apart), ``--repeat`` times each, in alternating order,
  medians and their ratio; every run must give the same root hash;
* the scheduler's overhead per task: ``--empty-tasks`` tasks that do nothing, sent through
  the same ``map_unordered`` as the shards (progress topic included), in ms per task beyond
  the first (whose time is the engine's start-up per call), and the extra time per shard
  task the Dask run took over the local pool's;
* the projected time to generate 1,000,000 episodes on 100 machines x 16 cores, from the
  measured per-core rate and overheads, with its assumptions.

The figures assume the cores are ours alone; on a shared machine both engines slow down
alike, and the ratio is the figure to read.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from nsrmp_bench.engine import TaskReport, open_engine
from nsrmp_bench.generators.generate import generate_part
from nsrmp_bench.split_specs import load_split


def empty(k: int, *, report: TaskReport) -> int:
    """A task that does nothing: what is left of its time is the engine's."""
    report.advance()
    return k


def timed_generation(engine: Any, split: str, part: str, limit: int,
                     shard_size: int) -> tuple[float, str, int]:
    """Seconds, root hash and bytes on disk of one generation into a fresh folder."""
    spec = load_split(split)
    with tempfile.TemporaryDirectory(prefix="bench-dask-") as out:
        start = time.perf_counter()
        manifest, _ = generate_part(spec, part, out, engine=engine, shard_size=shard_size,
                                    limit=limit)
        seconds = time.perf_counter() - start
        size = sum(p.stat().st_size for p in Path(out).glob("shard-*.h5"))
    return seconds, manifest.root_hash, size


def empty_tasks(engine: Any, n: int) -> tuple[float, float]:
    """Seconds of one empty task (the engine's start-up per call: a local pool spawns its
    processes) and milliseconds per further task, from ``n`` of them on every worker."""
    list(engine.map_unordered(empty, [(0,)]))  # warm the path (imports)
    start = time.perf_counter()
    list(engine.map_unordered(empty, [(0,)]))
    one = time.perf_counter() - start
    start = time.perf_counter()
    list(engine.map_unordered(empty, [(k,) for k in range(n)]))
    return one, (time.perf_counter() - start - one) / (n - 1) * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--split", default="paper-v2")
    parser.add_argument("--part", default="test")
    parser.add_argument("--limit", type=int, default=300)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--shard-size", type=int, default=25)
    parser.add_argument("--empty-tasks", type=int, default=200)
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    n, w = args.limit, args.workers
    shards = -(-n // args.shard_size)
    print(f"{args.split}/{args.part}, first {n} instances, shards of {args.shard_size} "
          f"({shards} tasks), {w} workers")

    local_s: list[float] = []
    dask_s: list[float] = []
    roots: set[str] = set()
    start = time.perf_counter()
    with open_engine("dask", workers=w) as dask:
        cluster_start = time.perf_counter() - start
        for r in range(args.repeat):  # alternate which goes first: the load of others varies
            for name in ("local", "dask") if r % 2 == 0 else ("dask", "local"):
                with contextlib.ExitStack() as stack:
                    engine = dask if name == "dask" else stack.enter_context(
                        open_engine("local", workers=w))
                    seconds, root, size = timed_generation(engine, args.split, args.part, n,
                                                           args.shard_size)
                (dask_s if name == "dask" else local_s).append(seconds)
                roots.add(root)
        _, dask_ms = empty_tasks(dask, args.empty_tasks)
    with open_engine("local", workers=w) as local:
        pool_start, pool_ms = empty_tasks(local, args.empty_tasks)
    t_local, t_dask = statistics.median(local_s), statistics.median(dask_s)
    same = "same root hash" if len(roots) == 1 else "ROOT HASHES DIFFER"
    runs = ", ".join(f"{a:.1f}/{b:.1f}" for a, b in zip(local_s, dask_s, strict=True))
    print(f"  seconds per run, local/dask: {runs} (medians below)")
    print(f"  local pool:        {n / t_local:6.2f} ep/s ({t_local:.1f} s, starting its "
          f"processes included: {pool_start:.1f} s for one empty task)")
    print(f"  Dask LocalCluster: {n / t_dask:6.2f} ep/s ({t_dask:.1f} s on the running "
          f"cluster, started in {cluster_start:.1f} s before); {same}")
    print(f"  ratio Dask / local: {t_local / t_dask:.2f}x per generation call (goal >= 0.9x); "
          f"{t_local / (t_dask + cluster_start):.2f}x counting the cluster's start-up too "
          "(once per command)")
    per_shard_ms = (t_dask - t_local) * w / shards * 1e3
    print(f"  scheduler overhead: {dask_ms:.1f} ms per task on Dask ({pool_ms:.1f} ms on the "
          f"local pool), from {args.empty_tasks} empty tasks on {w} workers, beyond the "
          f"first; generation took {per_shard_ms:+.0f} ms per shard task on Dask against "
          "the local pool")
    empty_ms = dask_ms

    # -- projection: 1,000,000 episodes on 100 machines x 16 cores ---------------------
    episodes, cores, shard = 1_000_000, 100 * 16, 100
    per_core = n / t_local / w  # episodes per second per core, measured in this run
    tasks = episodes // shard
    compute_s = episodes / (cores * per_core)
    overhead_s = tasks * empty_ms / 1e3  # as if the scheduler handled tasks one at a time
    shard_s = shard / per_core
    rounds = -(-tasks // cores)  # every worker takes shards until none is left
    total_s = rounds * shard_s + overhead_s
    bytes_per_episode = size / n
    print("projection, 1,000,000 episodes on 100 machines x 16 cores (1,600 workers):")
    print(f"  {per_core:.2f} ep/s per core (measured in this run): {compute_s / 60:.1f} min of "
          f"compute if perfectly divided; {tasks:,} shards of {shard} take {shard_s:.0f} s "
          f"each, {rounds} rounds of them on {cores:,} workers = {rounds * shard_s / 60:.1f} "
          f"min; {tasks:,} x {empty_ms:.1f} ms = {overhead_s / 60:.1f} min of scheduler time "
          "if none of it overlapped")
    print(f"  total ~ {total_s / 60:.0f} min; the shared filesystem takes "
          f"{bytes_per_episode * episodes / 1e12:.2f} TB at "
          f"{bytes_per_episode * cores * per_core / 1e6:.0f} MB/s "
          f"({bytes_per_episode / 1e6:.2f} MB per episode); the scheduler sees "
          f"{tasks / (rounds * shard_s):.0f} tasks/s and up to "
          f"{cores * min(per_core, 1.0):.0f} progress events/s")
    print("  assumes: cores as fast as these and not shared; the paper-v2 mix (3-5 objects, "
          "1-2 steps); shards of 100 (smaller shards shorten the last round); one "
          "single-threaded worker per core; the filesystem keeps up; starting the cluster "
          "and the workers' first imports not counted")


if __name__ == "__main__":
    main()
