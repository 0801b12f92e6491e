"""The original NSRMP data generator's speed, measured on the local machine, one core.

    python benchmarks/bench_original_generator.py --tree /tmp/nsrmp-original
        [--template SingleStep] [--objects 5] [--language simple] [--type any]
        [--scenes 20] [--width 1024 --height 768] [--seed 0] [--repeat 1]
        [--core N] [--keep DIR]

(about 75-100 s per repeat with the defaults.)

What it measures: the §7.4 figure of ``shared/reference/nsrm-original-datagen.md``, *wall
seconds per sample with a demo.json*, of ``dair-iitd/nsrmp`` at commit ``bf6ba54``
(``data_generation/construct.py``) asked for ``--scenes`` scenes (``--num_examples``; up
to 3 instructions, so up to 3 samples, per scene, §5.1), each sample two 1024x768
TinyRenderer scenes (S00 and S01) written as rgba/depth/mask PNGs, robot motion not
simulated (objects teleported). Our generator's speed is stated against this
figure, so it must be measured on the same machine as ours: ``benchmarks/bench_generate.py``
prints our side.

How (the method of §7.1-7.3): no file of the original tree is modified. The run is
``nsrmp_bench.generators.original.run.run_original``: a fresh Python process (the shim file,
``generators/original/shim.py``, run as a script: the parent's imports do not count, the
child's own imports of PyBullet, NumPy, OpenCV and Pillow do) pinned to one core
(``os.sched_setaffinity``, the same core every run; default the last one) imports PyBullet
and replaces three functions on the ``pybullet`` module object:

1. ``connect(GUI, ...)`` by ``connect(DIRECT)``;
2. ``resetDebugVisualizerCamera(**kw)`` by storing ``kw``;
3. ``getCameraImage(w, h)`` without matrices by the GUI mode's own camera (§1.9):
   view = ``computeViewMatrixFromYawPitchRoll(stored target, distance, yaw, pitch, roll 0,
   up axis z)``, projection = ``computeProjectionMatrix(-a*0.01, a*0.01, -0.01, 0.01,
   0.01, 1000)`` with a = w/h, renderer ``ER_TINY_RENDERER``. This reproduces the shipped
   ``examples/00001`` bit-exactly (§1.9).

It then seeds Python's ``random`` and ``np.random`` with ``--seed`` (the original seeds
nothing, §6.1; seeding changes no file and makes runs comparable; ``PYTHONHASHSEED`` is
fixed too) and runs ``construct.py`` unchanged as ``__main__`` (``runpy``) with the working
directory and ``sys.path[0]`` = the tree's ``data_generation`` folder, the command line of
§7.3 (``--template_file ./panda/construct/templates/<T>.json --metadata_file
./panda/construct/metadata.json --type --max_objects --language --num_examples``), into a
temporary dataset folder removed afterwards (``--keep DIR`` keeps it). ``--width/--height``
are passed only when they are not the original's own defaults (1024x768): its parser
reads them as strings, which the shim turns into ints. ``PYTHONBREAKPOINT=0`` disarms the
``breakpoint()`` left at ``program_generator.py:130`` (it then raises as it would after
``continue``). The same run makes the cross-generator TEST part
(``nsrmp-bench import-original``).

Printed per repeat and as the median of the repeats: wall seconds of the child process
(start to exit, everything included), its CPU seconds, the seconds inside ``runpy``,
scenes requested, sample folders, samples with ``demo.json`` and wall / sample with
``demo.json``; the phrasing drawn (``--language complex`` draws complex or compound once
per run, from the seed); the "NO compatible program found" count and the child's other messages (the
original catches every exception of a scene and prints it, §6.8-6.11; "Not connected to
physics server" after every successful scene is expected, §6.11); the load average before
and after.

Get the tree: ``git clone https://github.com/dair-iitd/nsrmp && git -C nsrmp checkout
bf6ba54`` (or export it file by file from a mirror, skipping the missing
``data_generation/log.txt``, §7.1). Needs ``pybullet numpy opencv-python-headless pillow``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from nsrmp_bench.errors import InvalidArgument, NSRMPError
from nsrmp_bench.generators.original.run import OriginalRun, RunSpec, run_original
from nsrmp_bench.generators.original.tree import (
    NEEDED_MODULES,
    check_modules,
    data_generation_dir,
)

__all__ = ["NEEDED_MODULES", "OriginalGeneratorError", "check_modules", "data_generation_dir",
           "main", "original_seconds_per_sample", "pick_core"]

OriginalGeneratorError = NSRMPError
"""What this script raises: the package's errors (a bad tree or value, a missing module,
a run that failed or produced nothing), each saying why and what to do."""


def pick_core(core: int | None) -> int | None:
    """The core to pin the child to (``core``, default the last allowed one), or None
    where ``os.sched_setaffinity`` does not exist."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    allowed = sorted(os.sched_getaffinity(0))
    if core is None:
        return allowed[-1]
    if core not in allowed:
        msg = (
            f"--core {core}: this process may run only on cores {allowed}; pass one of them "
            f"(or leave --core out for the last, {allowed[-1]})")
        raise InvalidArgument(msg)
    return core


def original_seconds_per_sample(
        tree: Path, *, scenes: int, seed: int, template: str = "SingleStep", objects: int = 5,
        language: str = "simple", object_type: str = "any", width: int = 1024,
        height: int = 768, core: int | None = None, keep: Path | None = None) -> OriginalRun:
    """Runs the original generator once (see the module doc) and times it.

    ``keep``: a folder that must not exist yet; the dataset (``keep/dataset``) and the
    child's output (``keep/dataset.log``) are left there instead of being removed.
    Raises the package's errors for a bad tree, template, value, core or a missing module,
    and when the child fails or writes no sample with a demo.json.
    """
    spec = RunSpec(template, objects, language, scenes, seed, object_type, width, height)
    spec.check()
    data_generation_dir(tree, template)
    check_modules()
    pin = pick_core(core)
    if keep is not None:
        keep = Path(keep).resolve()
        if keep.exists():
            msg = (
                f"--keep {keep} exists; the original numbers samples by the folder's entry "
                "count, so it needs a new folder: pass a path that does not exist yet")
            raise InvalidArgument(msg)
        keep.mkdir(parents=True)
        work = keep
    else:
        work = Path(tempfile.mkdtemp(prefix="nsrmp-original-"))
    try:
        return run_original(tree, work / "dataset", spec, core=pin)
    finally:
        if keep is None:
            shutil.rmtree(work, ignore_errors=True)


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.2f} (1 min), {five:.2f} (5 min)"


def main(argv: Sequence[str] | None = None) -> int:
    args_in = list(sys.argv[1:] if argv is None else argv)
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    ap.add_argument("--tree", type=Path, required=True,
                    help="root of dair-iitd/nsrmp at bf6ba54 (holds data_generation/)")
    ap.add_argument("--template", default="SingleStep",
                    help="a file of data_generation/panda/construct/templates/, no .json")
    ap.add_argument("--objects", type=int, default=5, help="--max_objects")
    ap.add_argument("--language", default="simple", choices=["simple", "complex"])
    ap.add_argument("--type", dest="object_type", default="any", choices=["any", "cube"])
    ap.add_argument("--scenes", type=int, default=20, help="--num_examples")
    ap.add_argument("--width", type=int, default=1024)
    ap.add_argument("--height", type=int, default=768)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--core", type=int, default=None, help="default: the last core")
    ap.add_argument("--keep", type=Path, default=None,
                    help="keep the datasets here (DIR/run-<i>/dataset); must not exist")
    args = ap.parse_args(args_in)
    if args.repeat < 1:
        ap.error(f"--repeat {args.repeat}: expected at least 1")
    try:
        pin = pick_core(args.core)
        data_generation_dir(args.tree, args.template)
        print(f"original generator {args.tree} ({args.template}, {args.objects} objects, "
              f"{args.language}, type {args.object_type}, {args.scenes} scenes, "
              f"{args.width}x{args.height}, seed {args.seed}), "
              + (f"pinned to core {pin}" if pin is not None else "not pinned (no affinity)"))
        runs = []
        for i in range(args.repeat):
            print(f"  run {i + 1}/{args.repeat}: before, {_load()}", flush=True)
            run = original_seconds_per_sample(
                args.tree, scenes=args.scenes, seed=args.seed, template=args.template,
                objects=args.objects, language=args.language, object_type=args.object_type,
                width=args.width, height=args.height, core=pin,
                keep=None if args.keep is None else args.keep / f"run-{i + 1}")
            runs.append(run)
            runpy_s = "?" if run.runpy_s is None else f"{run.runpy_s:.1f}"
            print(f"  run {i + 1}/{args.repeat}: wall {run.wall_s:.1f} s (CPU {run.cpu_s:.1f} s, "
                  f"construct.py {runpy_s} s), {run.spec.scenes} scenes, {run.sample_dirs} "
                  f"sample dirs, {len(run.samples)} with demo.json: "
                  f"{run.seconds_per_sample:.3f} s / sample; language "
                  f"{'/'.join(run.languages)}; {run.no_program} x no program; after, "
                  f"{_load()}")
            for message, count in run.other_messages[:8]:
                print(f"      {count:3d} x {message}")
            if args.keep is not None:
                print(f"      kept: {run.dataset}")
    except OriginalGeneratorError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    med = statistics.median
    print(f"median of {len(runs)}: wall {med(r.wall_s for r in runs):.1f} s, "
          f"{med(len(r.samples) for r in runs):g} samples with demo.json, "
          f"{med(r.seconds_per_sample for r in runs):.3f} s / sample (wall), "
          f"{med(r.cpu_s / max(len(r.samples), 1) for r in runs):.3f} s / sample (CPU)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
