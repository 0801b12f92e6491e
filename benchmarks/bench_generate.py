"""Generation speed before and after the lean reset and the writer thread, side by side.

    python benchmarks/bench_generate.py [--split paper-v2] [--part test] [--episodes 100]
                                        [--repeat 5] [--large 100] [--forked] [--breakdown]
                                        [--original-tree DIR [--original-scenes 20]]
                                        [--heap-default] [--writer [--large N]]
                                        [--writer-ablation [--large N]]

(about 5 minutes with the defaults: each end-to-end run writes one whole shard of 100
episodes, as the ``generate`` verb does, so the shard's fork and commit count as often as
they do there.)

"before" is the generator as it was: ``World(lean_reset=False)`` (every instance reloads
the table, the Panda and their visuals from the shipped files) and
``shard_writer(background=False)`` (hash, compress and write in the generating thread).
"after" is what ``generate`` runs now: ``World()`` (teleport instances begin with the
resting arm's collision hulls reduced to their bounding points, ``World.begin(...,
robot_collision=False)``) and ``shard_writer(background="process")`` (hash, compress and
write in a child process forked for the shard, the images handed over through shared
memory, :mod:`~nsrmp_bench.storage.handover`: what ``generate`` does with one worker on a
machine of two cores or more, ``generate.shard_writer_mode``), whose lean instances run in
a client without a renderer and are drawn by the objects' render twin
(:mod:`~nsrmp_bench.generators.world.object_twin`). "lean" is "after" without the twin
(``World(object_twin=False)``: every body and render in one client, the generator before
the twin). All three make the same bytes
(``tests/world/test_determinism.py``, ``tests/world/test_robot_clearance.py``,
``tests/storage/test_writer_background.py``, and ``generate`` + ``verify`` of every
committed part).

The two run in this one process, in alternating order (before, after, after, before, ...),
``--repeat`` times over the first ``--episodes`` instances of the part; every figure is
the median over the repeats, so a machine shared with other jobs slows both alike.
Printed:

* ``World.begin``'s share of ``make_episode`` (milliseconds per instance of each);
* one worker end to end: episodes per second of shards written the way the ``generate``
  verb's worker writes them (``make_episode`` into a ``ShardWriter``, committed: hashed,
  compressed, fsynced, renamed), and the ratio of that to generating alone (after);
* 1024x768 (the original generator's image size): seconds per episode end to end, against
  the original's 1.02 s per sample on one core of a reference machine
  (the original's documented figure) and, with ``--original-tree`` (a
  checkout of ``dair-iitd/nsrmp`` at ``bf6ba54``), against the original measured in the same run, in
  the same alternation (``benchmarks/bench_original_generator.py``: ``--original-scenes``
  scenes of SingleStep, 5 objects, simple, seed 0, pinned to one core; wall seconds per
  sample with a demo.json).

Like ``generate``'s workers, the process first keeps the memory its renders free for the
next ones (:func:`~nsrmp_bench.generators.world.heap.retain_freed_memory`);
``--heap-default`` leaves glibc's thresholds alone (the generator before that change).

``--breakdown`` first prints what one object body costs to create, per shape: with its
visual shape in a client with a renderer (as the world made them before the twin) and
without one in the physics-only client (as it makes them now); and what a 1024x768
composite render costs copied into an episode's fresh arrays (as ``realise`` did) against
written into them (``World.render(out=...)``, what it does now).

``--breakdown`` then prints what an episode costs at 320x240 and 1024x768 with glibc's
thresholds as they are against raised (CPU ms of ``make_episode`` and page faults per
episode, each in a fresh process, alternating).

``--forked`` adds a third variant, "forked": ``World()`` primed once as a template and every
instance made in a child forked from it (:func:`~nsrmp_bench.generators.world.template.
run_forked`), so that its ``begin`` reloads nothing. Its CPU time counts the children's.

``--writer`` prints only what the writer process does per episode (it runs the synchronous
writer, the code the process runs): CPU ms of writing ``--episodes`` instances made
beforehand into a committed shard, and within it the episode's SHA-256 and the DEFLATE of
its images (Python's ``zlib``, level 1, shuffled floats, as HDF5's filters), medians of
``--repeat`` runs, at the part's image size and (``--large`` > 0) at 1024x768 for
``--large`` instances.

``--writer`` also prints the same writer's CPU with every image chunk compressed whole
(the compression not resumed after the background's rows, :mod:`~nsrmp_bench.storage.
prefix_deflate`), alternating with the rest.

``--writer-ablation`` times only one worker end to end with the writer process, four
ways alternating, and generating alone: as shipped (the writer compresses the image chunks
with Python's ``zlib`` and stores them as they are, and while it lags the generator
compresses chunks of the episode it hands over rather than wait, :func:`~nsrmp_bench.
storage.chunks.precompress`); every chunk compressed whole (not resumed after the
background's rows); without the generator's share; and with HDF5's own filter
compressing in the writer (both changes undone: the writer of ``d6037cd``), ``--repeat``
runs of ``--episodes`` instances at the part's image size, or ``--large`` at 1024x768.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import importlib.metadata
import json
import multiprocessing
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from nsrmp_bench.generators.generate import make_episode
from nsrmp_bench.generators.world.heap import retain_freed_memory
from nsrmp_bench.generators.world.template import run_forked
from nsrmp_bench.generators.world.world import World
from nsrmp_bench.geometry.default_camera import official_camera
from nsrmp_bench.split_specs import SplitSpec, load_split
from nsrmp_bench.storage import h5_objects
from nsrmp_bench.storage import writer as writer_module
from nsrmp_bench.storage.arrays import episode_arrays
from nsrmp_bench.storage.chunks import precompress
from nsrmp_bench.storage.handover import Handover
from nsrmp_bench.storage.hashing import episode_hash
from nsrmp_bench.storage.prefix_deflate import PrefixDeflater
from nsrmp_bench.storage.writer import Background, shard_writer

ORIGINAL_S_PER_SAMPLE = 1.02
"""The original generator, 1024x768, one core of a reference machine (see the module doc)."""


def cpu_s() -> float:
    """CPU seconds of this process and of its reaped children (the forked instances)."""
    own, kids = (resource.getrusage(who) for who in (resource.RUSAGE_SELF,
                                                      resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


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
        self.forked = False

    def episode(self, spec: SplitSpec, part: str, index: int) -> Any:
        """Instance ``index``, made here or (``forked``) in a child of the primed world,
        whose ``begin`` time is added to this one's."""
        if not self.forked:
            return make_episode(spec, part, index, self.world)

        def child() -> tuple[Any, float]:
            self.begin_s = 0.0
            return make_episode(spec, part, index, self.world), self.begin_s

        episode, begin_s = run_forked(self.world, child)
        self.begin_s += begin_s
        return episode


def generate_only(spec: SplitSpec, part: str, n: int, timed: TimedWorld) -> tuple[float, float]:
    """(CPU ms per instance of make_episode, CPU ms per instance of World.begin in it).

    CPU time, not wall time: on a shared machine the wall clock also counts the time the
    scheduler gave to other jobs; generating is single-threaded, so its CPU time is its
    cost."""
    timed.begin_s = 0.0
    start = cpu_s()
    for i in range(n):
        timed.episode(spec, part, i)
    total = cpu_s() - start
    return total / n * 1e3, timed.begin_s / n * 1e3


def generate_alone(spec: SplitSpec, part: str, n: int, timed: TimedWorld) -> tuple[float, float]:
    """(wall, CPU) seconds per instance of generating the first ``n`` alone, the figures
    :func:`end_to_end` is compared with."""
    wall = time.perf_counter()
    cpu_ms = generate_only(spec, part, n, timed)[0]
    return (time.perf_counter() - wall) / n, cpu_ms / 1e3


def end_to_end(spec: SplitSpec, part: str, n: int, timed: TimedWorld,
               background: Background) -> tuple[float, float, float, float]:
    """(wall, CPU) seconds per episode of making the first ``n`` instances into a committed
    shard, then the wall seconds the caller spent opening the writer (a writer process's
    fork) and in its commit (what was left to write, the file's fsync and hash). The CPU
    time counts the writer thread or process (and forked children) too."""
    with tempfile.TemporaryDirectory(prefix="bench-generate-") as out:
        wall, cpu = time.perf_counter(), cpu_s()
        with shard_writer(out, 0, n, split=f"{spec.id}/{part}", background=background) as w:
            opened = time.perf_counter()
            for i in range(n):
                w.add(timed.episode(spec, part, i))
            committing = time.perf_counter()
            w.commit()
            done = time.perf_counter()
        elapsed = time.perf_counter() - wall
        for child in multiprocessing.active_children():  # the writer process: its CPU
            if child.name.startswith("writer "):  # counts once reaped, which the writer
                child.join(timeout=60)  # leaves to multiprocessing
        return elapsed / n, (cpu_s() - cpu) / n, opened - wall, done - committing


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


def body_costs(n: int = 200) -> None:
    """Print CPU ms per ``createMultiBody`` of each shape, with and without the renderer."""
    import pybullet as pb

    from nsrmp_bench.generators.world.assets import create_shape_ids
    from nsrmp_bench.generators.world.object_twin import physics_only_client

    clients = {"with its visual, renderer on": (int(pb.connect(pb.DIRECT)), True),
               "no visual, physics-only client": (physics_only_client(pb), False)}
    print("one object body, CPU ms per createMultiBody (median of 5 runs of "
          f"{n} bodies):")
    for shape in ("cube", "dice", "lego"):
        row = []
        for label, (c, visual) in clients.items():
            runs = []
            for _ in range(5):
                pb.resetSimulation(physicsClientId=c)
                ids = create_shape_ids(pb, c, shape)
                start = time.process_time()
                for i in range(n):
                    pb.createMultiBody(baseMass=0.1, baseCollisionShapeIndex=ids.collision,
                                       baseVisualShapeIndex=ids.visual if visual else -1,
                                       basePosition=[2.0 * i, 50.0, -20.0],
                                       physicsClientId=c)
                runs.append((time.process_time() - start) / n * 1e3)
            row.append(f"{label} {med(runs):.3f}")
        print(f"  {shape:5s}: " + "; ".join(row))
    for c, _ in clients.values():
        pb.disconnect(physicsClientId=c)


def render_costs(spec: SplitSpec, part: str, rounds: int = 10) -> None:
    """Print CPU ms per 1024x768 composite render of a settled instance, copied into an
    episode's fresh arrays against written into them (``out=``), alternating."""
    import numpy as np

    from nsrmp_bench.generators.world.world import RenderedImages

    cam = official_camera(1024, 768)
    world = World(cam)
    for i in range(2):  # the second instance is lean and leaves its objects settled
        make_episode(spec, part, i, world)
    shape = (3, cam.height, cam.width)

    def copied() -> None:
        rgb, depth = np.empty((*shape, 3), np.uint8), np.empty(shape, np.float32)
        seg = np.empty(shape, np.int16)
        for k in range(3):
            images = world.render(cam, composite=True)
            rgb[k], depth[k], seg[k] = images.rgb, images.depth, images.segmentation

    def written() -> None:
        rgb, depth = np.empty((*shape, 3), np.uint8), np.empty(shape, np.float32)
        seg = np.empty(shape, np.int16)
        for k in range(3):
            world.render(cam, composite=True, out=RenderedImages(rgb[k], depth[k], seg[k]))

    def per_render(fn: Callable[[], None]) -> float:
        start = time.process_time()
        for _ in range(5):
            fn()
        return (time.process_time() - start) / 15 * 1e3

    runs = alternate(rounds, {"copied": lambda: per_render(copied),
                              "written": lambda: per_render(written)})
    pairs = [w / c for w, c in zip(runs["written"], runs["copied"], strict=True)]
    print(f"1024x768 composite render, CPU ms (median of {rounds} alternating runs of 15): "
          f"copied into the episode's arrays {med(runs['copied']):.1f}, written into them "
          f"{med(runs['written']):.1f} ({med(pairs):.2f}x pair by pair)")
    world.close()


def heap_probe(mode: str, split: str, part: str, n: int, image: tuple[int, int]) -> None:
    """Child of :func:`heap_costs`: print a JSON line of CPU ms and minor page faults per
    ``make_episode`` at ``image`` (width, height) over instances ``0..n-1``, with glibc's
    thresholds as they are (``mode`` "default") or raised ("retained")."""
    if mode == "retained":
        retain_freed_memory()
    spec = load_split(split)
    world = World(official_camera(*image))
    timed = TimedWorld(world)
    generate_only(spec, part, 3, timed)  # warm up: the cached background, the twin's pools
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    cpu_ms = generate_only(spec, part, n, timed)[0]
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - faults
    print(json.dumps({"cpu_ms": cpu_ms, "faults": faults / n}))


def heap_costs(split: str, part: str, n: int = 40, rounds: int = 3) -> None:
    """Print an episode's CPU ms and page faults at 320x240 and 1024x768 with glibc's
    thresholds as they are against raised, each run a fresh process (the thresholds cannot
    be put back)."""

    def run(mode: str, image: tuple[int, int]) -> dict[str, float]:
        out = subprocess.run(
            [sys.executable, str(Path(__file__).resolve()), "--split", split, "--part", part,
             "--heap-probe", mode, "--heap-image", f"{image[0]}x{image[1]}",
             "--episodes", str(n)],
            check=True, capture_output=True, text=True).stdout
        result: dict[str, float] = json.loads(out.strip().splitlines()[-1])
        return result

    for image in ((320, 240), (1024, 768)):
        runs = alternate(rounds, {mode: functools.partial(run, mode, image)
                                  for mode in ("default", "retained")})
        pairs = [r["cpu_ms"] / d["cpu_ms"]
                 for d, r in zip(runs["default"], runs["retained"], strict=True)]

        def fig(rows: list[dict[str, float]]) -> str:
            return ", ".join(f"{med([r[k] for r in rows]):.1f}" for k in ("cpu_ms", "faults"))

        print(f"{image[0]}x{image[1]} make_episode, {n} instances, CPU ms and minor page "
              f"faults per episode (median of {rounds} alternating processes): glibc's "
              f"thresholds as they are {fig(runs['default'])}; raised (retain_freed_memory) "
              f"{fig(runs['retained'])} ({med(pairs):.2f}x the CPU pair by pair, "
              f"{min(pairs):.2f}-{max(pairs):.2f})")


def original_run(tree: Path, scenes: int) -> tuple[float, float]:
    """(wall, CPU) seconds per sample of the original generator at 1024x768, measured in this run
    (``benchmarks/bench_original_generator.py``, imported from beside this script)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    try:
        from bench_original_generator import original_seconds_per_sample
    finally:
        sys.path.pop(0)
    run = original_seconds_per_sample(tree, scenes=scenes, seed=0)
    return run.seconds_per_sample, run.cpu_s / run.samples


@contextlib.contextmanager
def compression_resumed(resumed: bool) -> Iterator[None]:
    """With ``resumed`` False, while active every writer compresses each image chunk whole
    with ``zlib.compress``, as before :mod:`~nsrmp_bench.storage.prefix_deflate` (the same
    bytes); with True, nothing changes."""
    shipped = PrefixDeflater.compress
    if not resumed:
        PrefixDeflater.compress = (  # type: ignore[method-assign]
            lambda self, raw, level, kind: zlib.compress(raw, level))
    try:
        yield
    finally:
        PrefixDeflater.compress = shipped  # type: ignore[method-assign]


def writer_costs(spec: SplitSpec, part: str, n: int, repeat: int,
                 image: tuple[int, int]) -> None:
    """Print the synchronous writer's CPU ms per episode and its hash and DEFLATE parts,
    and the same writer without the resumed compression."""
    world = World(official_camera(*image))
    episodes = [make_episode(spec, part, i, world) for i in range(n)]

    def write(resumed: bool = True) -> float:
        with tempfile.TemporaryDirectory(prefix="bench-writer-") as out, \
                compression_resumed(resumed):
            start = time.process_time()
            with shard_writer(out, 0, n, split=f"{spec.id}/{part}", background=False) as w:
                for episode in episodes:
                    w.add(episode)
                w.commit()
            return (time.process_time() - start) / n * 1e3

    def hashing() -> float:
        start = time.process_time()
        for episode in episodes:
            episode_hash(episode)
        return (time.process_time() - start) / n * 1e3

    def deflate() -> float:
        start = time.process_time()
        for episode in episodes:
            precompress(episode_arrays(episode), until=lambda: False)  # every chunk
        return (time.process_time() - start) / n * 1e3

    rows = alternate(repeat, {"write": write, "hash": hashing, "deflate": deflate,
                              "not resumed": lambda: write(resumed=False)})
    total, sha, comp, plain = (med(rows[k]) for k in ("write", "hash", "deflate",
                                                        "not resumed"))
    pairs = [w / p for w, p in zip(rows["write"], rows["not resumed"], strict=True)]
    print(f"writer, {spec.id}/{part}, {n} episodes at {image[0]}x{image[1]}, CPU ms per "
          f"episode, medians of {repeat}: {total:.1f} in all; SHA-256 {sha:.1f}, DEFLATE of "
          f"the images (each whole) {comp:.1f}, the rest (HDF5 objects, flush, commit) "
          f"{total - sha - comp:.1f}; without the resumed compression {plain:.1f} in all "
          f"({med(pairs):.3f}x the CPU pair by pair, {min(pairs):.3f}-{max(pairs):.3f})")


def writer_ablation(spec: SplitSpec, part: str, n: int, repeat: int,
                    image: tuple[int, int]) -> None:
    """One worker end to end with the writer process four ways, alternating: as shipped
    (chunks compressed by the writer with Python's zlib, resumed after the background's
    rows, and by the generator while the writer lags), every chunk compressed whole,
    without the generator's share, and with HDF5's filter compressing in the writer (the
    writer before these changes); and generating alone."""
    timed = TimedWorld(World(official_camera(*image)))
    timed.episode(spec, part, 0)
    free, idle, put = Handover.free, Handover.idle, writer_module._put_image

    def hdf5_filter(group: Any, path: str, name: str, arr: Any, kw: Any, *_: Any) -> None:
        h5_objects.dataset(group, name, arr, kw)

    def variant(share: bool, python_zlib: bool,
                resumed: bool = True) -> Callable[[], tuple[float, ...]]:
        def run() -> tuple[float, ...]:
            Handover.free = free if share else lambda self: True  # type: ignore[method-assign]
            Handover.idle = idle if share else lambda self: True  # type: ignore[method-assign]
            writer_module._put_image = put if python_zlib else hdf5_filter
            try:
                with compression_resumed(resumed):
                    return end_to_end(spec, part, n, timed, "process")
            finally:
                Handover.free, Handover.idle = free, idle  # type: ignore[method-assign]
                writer_module._put_image = put
        return run

    rows = alternate(repeat, {"shipped": variant(True, True),
                              "compression not resumed": variant(True, True, resumed=False),
                              "writer compresses alone": variant(False, True),
                              "HDF5's filter, writer alone": variant(False, False),
                              "generate only": lambda: generate_alone(spec, part, n, timed)})
    print(f"writer process, {spec.id}/{part}, {n} episodes at {image[0]}x{image[1]}, wall ms "
          f"per episode, medians of {repeat} alternating runs:")
    for name, xs in rows.items():
        line = f"  {name:28s} {med([x[0] for x in xs]) * 1e3:6.1f}"
        if name not in ("shipped", "generate only"):
            pairs = [b[0] / a[0] for a, b in zip(rows["shipped"], xs, strict=True)]
            line += (f"; shipped's speed against it {med(pairs):.3f}x "
                     f"({min(pairs):.3f}-{max(pairs):.3f}), pair by pair")
        print(line)
    for name in ("shipped", "compression not resumed", "HDF5's filter, writer alone"):
        ratio = [g[0] / a[0] for a, g in zip(rows[name], rows["generate only"], strict=True)]
        print(f"  end to end / generate only, {name}: {med(ratio):.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--split", default="paper-v2")
    parser.add_argument("--part", default="test")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--large", type=int, default=100,
                        help="episodes per 1024x768 run (0: skip)")
    parser.add_argument("--forked", action="store_true",
                        help="add the variant that makes every instance in a forked child")
    parser.add_argument("--breakdown", action="store_true",
                        help="first print what one object body costs, per shape")
    parser.add_argument("--original-tree", type=Path, default=None,
                        help="a checkout of dair-iitd/nsrmp (bf6ba54): also time the "
                             "original generator at 1024x768 here")
    parser.add_argument("--original-scenes", type=int, default=20,
                        help="scenes per run of the original (up to 3 samples each)")
    parser.add_argument("--writer", action="store_true",
                        help="only print what the writer process does per episode")
    parser.add_argument("--writer-ablation", action="store_true",
                        help="only time the writer process with and without its two "
                             "compression changes, end to end (with --large: 1024x768)")
    parser.add_argument("--heap-default", action="store_true",
                        help="leave glibc's mmap and trim thresholds as they are")
    parser.add_argument("--heap-probe", choices=("default", "retained"),
                        help=argparse.SUPPRESS)
    parser.add_argument("--heap-image", default="1024x768", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.heap_probe is not None:
        width, height = (int(v) for v in args.heap_image.split("x"))
        heap_probe(args.heap_probe, args.split, args.part, args.episodes, (width, height))
        return
    if not args.heap_default:
        retain_freed_memory()
    if args.writer:
        spec = load_split(args.split)
        writer_costs(spec, args.part, args.episodes, args.repeat, spec.image)
        if args.large > 0:
            writer_costs(spec, args.part, args.large, max(1, args.repeat // 2), (1024, 768))
        return
    if args.writer_ablation:
        spec = load_split(args.split)
        if args.large > 0:
            writer_ablation(spec, args.part, args.large, args.repeat, (1024, 768))
        else:
            writer_ablation(spec, args.part, args.episodes, args.repeat, spec.image)
        return
    if args.breakdown:
        body_costs()
        render_costs(load_split(args.split), args.part)
        heap_costs(args.split, args.part)
    spec = load_split(args.split)
    part, n = args.part, args.episodes
    pybullet = importlib.metadata.version("pybullet")
    patched = " (the patched build of scripts/build_pybullet.py)" if "+nsrmp" in pybullet else ""
    print(f"load average at start: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores); "
          f"pybullet {pybullet}{patched}")
    cam = official_camera(*spec.image)
    timed = {"before": TimedWorld(World(cam, lean_reset=False)),
             "lean": TimedWorld(World(cam, object_twin=False)),
             "after": TimedWorld(World(cam))}
    if args.forked:
        timed["forked"] = TimedWorld(World(cam))
        timed["forked"].forked = True
    for t in timed.values():  # warm up: assets, cached background, imports
        t.episode(spec, part, 0)
    writer: dict[str, Background] = {"before": False, "lean": "process", "after": "process",
                                     "forked": "process"}

    gen = alternate(args.repeat, {
        name: (lambda t=t: generate_only(spec, part, n, t)) for name, t in timed.items()})
    print(f"\n{spec.id}/{part}, instances 0..{n - 1}, {spec.image[0]}x{spec.image[1]}, "
          f"medians of {args.repeat} alternating runs, CPU time per instance")
    for name, rows in gen.items():
        ep = med([r[0] for r in rows])
        begin = med([r[1] for r in rows])
        share = med([r[1] / r[0] for r in rows])
        print(f"  {name:6s}: make_episode {ep:6.1f} ms, World.begin {begin:5.1f} ms "
              f"= {share:.1%} of an episode")

    e2e = alternate(args.repeat, {
        **{name: (lambda name=name, t=t: end_to_end(spec, part, n, t, writer[name]))
           for name, t in timed.items()},
        "after, generate only": lambda: generate_alone(spec, part, n, timed["after"]),
        # the writer of the step before: a thread, which waits for PyBullet's GIL
        "after, writer thread": lambda: end_to_end(spec, part, n, timed["after"], True),
    })
    print("\none worker, end to end (episodes into a committed shard):")
    for k, clock in ((0, "wall"), (1, "CPU")):
        rate = {name: 1.0 / med([r[k] for r in rows]) for name, rows in e2e.items()}
        alone = [g[k] / a[k] for g, a in zip(e2e["after, generate only"], e2e["after"],
                                             strict=True)]
        print(f"  {clock:4s}: " + ", ".join(f"{name} {rate[name]:5.1f} ep/s" for name in timed)
              + f"; end to end / generate only (after, {rate['after, generate only']:.1f} "
              f"ep/s alone): {med(alone):.2f}; after with a writer thread "
              f"{rate['after, writer thread']:.1f} ep/s")
        for name in (*timed, "after, writer thread"):
            if name == "after":
                continue
            pairwise = [a[k] / b[k] for b, a in zip(e2e[name], e2e["after"], strict=True)]
            print(f"        {name} against after, speed pair by pair: {med(pairwise):.2f}x "
                  f"({min(pairwise):.2f}-{max(pairwise):.2f})")
    after = e2e["after"]
    print(f"  after, the shard's start (the writer process's fork) "
          f"{med([r[2] for r in after]) * 1e3:.1f} ms and commit (the writing left, the "
          f"file's fsync and hash) {med([r[3] for r in after]) * 1e3:.1f} ms, wall")

    if args.large > 0:
        big = official_camera(1024, 768)
        worlds = {"before": TimedWorld(World(big, lean_reset=False)),
                  "lean": TimedWorld(World(big, object_twin=False)),
                  "after": TimedWorld(World(big))}
        if args.forked:
            worlds["forked"] = TimedWorld(World(big))
            worlds["forked"].forked = True
        for t in worlds.values():
            t.episode(spec, part, 0)
        runs: dict[str, Callable[[], tuple[float, ...]]] = {
            name: (lambda name=name, t=t: end_to_end(spec, part, args.large, t,
                                                     writer[name]))
            for name, t in worlds.items()}
        if args.original_tree is not None:
            runs["original"] = lambda: original_run(args.original_tree, args.original_scenes)
        large = alternate(max(1, args.repeat // 2), runs)
        print(f"\n1024x768, end to end, {args.large} episodes per run:")
        for name, xs in large.items():
            wall, cpu = med([x[0] for x in xs]), med([x[1] for x in xs])
            if name == "original":
                print(f"  original, measured in this run ({args.original_scenes} scenes per run, "
                      f"pinned to one core): {wall:.3f} s wall, {cpu:.3f} s CPU per sample")
                continue
            line = (f"  {name:6s}: {wall:.3f} s wall, {cpu:.3f} s CPU per episode: "
                    f"{ORIGINAL_S_PER_SAMPLE / wall:.1f}x / {ORIGINAL_S_PER_SAMPLE / cpu:.1f}x "
                    f"faster than the original's {ORIGINAL_S_PER_SAMPLE} s per sample")
            if "original" in large:
                here = [o[0] / x[0] for o, x in zip(large["original"], xs, strict=True)]
                line += (f"; {med(here):.1f}x ({min(here):.1f}-{max(here):.1f}) the original "
                         "measured in this run, wall, pair by pair")
            if name != "after":
                pairs = [a[0] / x[0] for a, x in zip(large["after"], xs, strict=True)]
                line += (f"; its speed against after's {med(pairs):.2f}x "
                         f"({min(pairs):.2f}-{max(pairs):.2f}), wall, pair by pair")
            print(line)
    print(f"\nload average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
