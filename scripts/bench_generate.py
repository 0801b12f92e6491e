"""Generation throughput, and what the per-instance reset of the world costs in it.

    python scripts/bench_generate.py [--split paper-v2] [--part train] [--episodes 400]
                                     [--workers 2] [--repeat 3]

Prints, for the first ``--episodes`` instances of the part:

* end to end: episodes per second of ``generate_part`` (the ``generate`` verb's code:
  spawned workers, physics, renders, HDF5 shards, manifest), median of ``--repeat`` runs
  into fresh temporary folders;
* in this process: milliseconds per instance of ``World.begin`` (reset the simulation,
  reload the table and the Panda, create the objects) and of ``make_episode`` as a whole,
  the share of the first in the second.

The figures assume the cores are ours alone; another busy process cuts them by ~40%
(``shared/reference/perf-limits.md`` §5).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time

from nsrmp_bench.generators.generate import generate_part, make_episode
from nsrmp_bench.generators.world.world import World
from nsrmp_bench.geometry.default_camera import official_camera
from nsrmp_bench.split_specs import load_split


def end_to_end(split: str, part: str, episodes: int, workers: int) -> float:
    """Episodes per second of one generation of the first ``episodes`` instances."""
    spec = load_split(split)
    with tempfile.TemporaryDirectory(prefix="bench-generate-") as out:
        start = time.perf_counter()
        generate_part(spec, part, out, workers=workers, limit=episodes)
        return episodes / (time.perf_counter() - start)


def in_process(split: str, part: str, episodes: int) -> tuple[float, float]:
    """Milliseconds per instance of ``World.begin`` and of ``make_episode``."""
    spec = load_split(split)
    with World(official_camera(*spec.image)) as world:
        start = time.perf_counter()
        made = [make_episode(spec, part, i, world) for i in range(episodes)]
        episode_ms = (time.perf_counter() - start) / episodes * 1e3
        start = time.perf_counter()
        for episode in made:
            world.begin(episode.symbolic.scene.objects)
        begin_ms = (time.perf_counter() - start) / episodes * 1e3
    return begin_ms, episode_ms


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--split", default="paper-v2")
    parser.add_argument("--part", default="train")
    parser.add_argument("--episodes", type=int, default=400)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    rates = [end_to_end(args.split, args.part, args.episodes, args.workers)
             for _ in range(args.repeat)]
    print(f"{args.split}/{args.part}, first {args.episodes} instances, {args.workers} workers: "
          f"{statistics.median(rates):.1f} ep/s median of {args.repeat} "
          f"({', '.join(f'{r:.1f}' for r in rates)})")
    n = min(args.episodes, 200)
    begin_ms, episode_ms = in_process(args.split, args.part, n)
    print(f"one process, {n} instances: World.begin {begin_ms:.1f} ms, make_episode "
          f"{episode_ms:.1f} ms per instance (the reset is {begin_ms / episode_ms:.0%})")


if __name__ == "__main__":
    main()
