"""Generation speed before and after the lean reset and the writer thread, side by side.

    python scripts/bench_generate.py [--split paper-v2] [--part test] [--episodes 40]
                                     [--repeat 5] [--large 4]

"before" is the generator as it was: ``World(lean_reset=False)`` (every instance reloads
the table, the Panda and their visuals from the shipped files) and
``ShardWriter(background=False)`` (hash, compress and write in the generating thread).
"after" is the default: ``World()`` and ``ShardWriter()``. Both make the same bytes
(``tests/world/test_determinism.py``, ``tests/storage/test_writer_background.py``).

The two run in this one process, in alternating order (before, after, after, before, ...),
``--repeat`` times over the first ``--episodes`` instances of the part; every figure is
the median over the repeats, so a machine shared with other jobs slows both alike.
Printed:

* ``World.begin``'s share of ``make_episode`` (milliseconds per instance of each);
* one worker end to end: episodes per second of shards written the way the ``generate``
  verb's worker writes them (``make_episode`` into a ``ShardWriter``, committed: hashed,
  compressed, fsynced, renamed), and the ratio of that to generating alone (after);
* 1024x768 (the original generator's image size): seconds per episode end to end, against
  the original's 1.02 s per sample on one core of this machine
  (``shared/reference/nsrm-original-datagen.md`` §7.4).
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from collections.abc import Callable
from typing import Any

from nsrmp_bench.generators.generate import make_episode
from nsrmp_bench.generators.world.world import World
from nsrmp_bench.geometry.default_camera import official_camera
from nsrmp_bench.split_specs import SplitSpec, load_split
from nsrmp_bench.storage.writer import ShardWriter

ORIGINAL_S_PER_SAMPLE = 1.02
"""The original generator, 1024x768, one core of this machine (see the module doc)."""


class TimedWorld:
    """Counts the CPU seconds ``world.begin`` takes (it wraps the instance's method)."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.begin_s = 0.0
        inner = world.begin

        def begin(*args: Any, **kwargs: Any) -> Any:
            start = time.process_time()
            try:
                return inner(*args, **kwargs)
            finally:
                self.begin_s += time.process_time() - start

        world.begin = begin  # type: ignore[method-assign,unused-ignore]


def generate_only(spec: SplitSpec, part: str, n: int, timed: TimedWorld) -> tuple[float, float]:
    """(CPU ms per instance of make_episode, CPU ms per instance of World.begin in it).

    CPU time, not wall time: on a shared machine the wall clock also counts the time the
    scheduler gave to other jobs; generating is single-threaded, so its CPU time is its
    cost."""
    timed.begin_s = 0.0
    start = time.process_time()
    for i in range(n):
        make_episode(spec, part, i, timed.world)
    total = time.process_time() - start
    return total / n * 1e3, timed.begin_s / n * 1e3


def end_to_end(spec: SplitSpec, part: str, n: int, world: World,
               background: bool) -> tuple[float, float]:
    """(wall, CPU) seconds per episode of making the first ``n`` instances into a committed
    shard. The CPU time counts the writer thread too."""
    with tempfile.TemporaryDirectory(prefix="bench-generate-") as out:
        wall, cpu = time.perf_counter(), time.process_time()
        with ShardWriter(out, 0, n, split=f"{spec.id}/{part}", background=background) as w:
            for i in range(n):
                w.add(make_episode(spec, part, i, world))
            w.commit()
        return (time.perf_counter() - wall) / n, (time.process_time() - cpu) / n


def alternate(repeat: int, runs: dict[str, Callable[[], Any]]) -> dict[str, list[Any]]:
    """Run every entry ``repeat`` times, in an order reversed on every other round."""
    out: dict[str, list[Any]] = {k: [] for k in runs}
    names = list(runs)
    for r in range(repeat):
        for name in (names if r % 2 == 0 else names[::-1]):
            out[name].append(runs[name]())
    return out


def med(xs: list[float]) -> float:
    return statistics.median(xs)


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--split", default="paper-v2")
    parser.add_argument("--part", default="test")
    parser.add_argument("--episodes", type=int, default=40)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--large", type=int, default=4,
                        help="episodes per 1024x768 run (0: skip)")
    args = parser.parse_args()
    spec = load_split(args.split)
    part, n = args.part, args.episodes
    print(f"load average at start: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores)")
    cam = official_camera(*spec.image)
    before = TimedWorld(World(cam, lean_reset=False))
    after = TimedWorld(World(cam))
    for t in (before, after):  # warm up: assets, cached background, imports
        make_episode(spec, part, 0, t.world)

    gen = alternate(args.repeat, {
        "before": lambda: generate_only(spec, part, n, before),
        "after": lambda: generate_only(spec, part, n, after),
    })
    print(f"\n{spec.id}/{part}, instances 0..{n - 1}, {spec.image[0]}x{spec.image[1]}, "
          f"medians of {args.repeat} alternating runs, CPU time per instance")
    share: dict[str, float] = {}
    for name, rows in gen.items():
        ep = med([r[0] for r in rows])
        begin = med([r[1] for r in rows])
        share[name] = med([r[1] / r[0] for r in rows])
        print(f"  {name:6s}: make_episode {ep:6.1f} ms, World.begin {begin:5.1f} ms "
              f"= {share[name]:.0%} of an episode")

    def generate_alone() -> tuple[float, float]:
        wall = time.perf_counter()
        cpu_ms = generate_only(spec, part, n, after)[0]
        return (time.perf_counter() - wall) / n, cpu_ms / 1e3

    e2e = alternate(args.repeat, {
        "before": lambda: end_to_end(spec, part, n, before.world, background=False),
        "after": lambda: end_to_end(spec, part, n, after.world, background=True),
        "after, generate only": generate_alone,
    })
    print("\none worker, end to end (episodes into a committed shard):")
    for k, clock in ((0, "wall"), (1, "CPU")):
        rate = {name: 1.0 / med([r[k] for r in rows]) for name, rows in e2e.items()}
        pairwise = [b[k] / a[k] for b, a in zip(e2e["before"], e2e["after"], strict=True)]
        alone = [g[k] / a[k] for g, a in zip(e2e["after, generate only"], e2e["after"],
                                             strict=True)]
        print(f"  {clock:4s}: before {rate['before']:5.1f} ep/s, after {rate['after']:5.1f} ep/s: "
              f"{med(pairwise):.2f}x pair by pair ({min(pairwise):.2f}-{max(pairwise):.2f}); "
              f"end to end / generate only (after, {rate['after, generate only']:.1f} ep/s "
              f"alone): {med(alone):.2f}")

    if args.large > 0:
        big = official_camera(1024, 768)
        worlds = {"before": World(big, lean_reset=False), "after": World(big)}
        for w in worlds.values():
            make_episode(spec, part, 0, w)
        large = alternate(max(1, args.repeat // 2), {
            "before": lambda: end_to_end(spec, part, args.large, worlds["before"], False),
            "after": lambda: end_to_end(spec, part, args.large, worlds["after"], True),
        })
        print(f"\n1024x768, end to end, {args.large} episodes per run:")
        for name, xs in large.items():
            wall, cpu = med([x[0] for x in xs]), med([x[1] for x in xs])
            print(f"  {name:6s}: {wall:.3f} s wall, {cpu:.3f} s CPU per episode: "
                  f"{ORIGINAL_S_PER_SAMPLE / wall:.1f}x / {ORIGINAL_S_PER_SAMPLE / cpu:.1f}x "
                  f"faster than the original's {ORIGINAL_S_PER_SAMPLE} s per sample")
    print(f"\nload average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
