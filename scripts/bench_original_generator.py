"""The original NSRMP data generator's speed, measured on the local machine, one core.

    python scripts/bench_original_generator.py --tree /tmp/nsrmp-original
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
figure, so it must be measured on the same machine as ours: ``scripts/bench_generate.py``
prints our side.

How (the method of §7.1-7.3): no file of the original tree is modified. A fresh Python
process (this file with ``--shim-child``: the parent's imports do not count, the child's
own imports of PyBullet, NumPy, OpenCV and Pillow do) pinned to one core
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
``continue``).

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
import collections
import importlib.util
import json
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ORIGINAL_COMMIT = "bf6ba543e04283a122a7275f7822a595b0a193b0"
GET_TREE = ("get it with `git clone https://github.com/dair-iitd/nsrmp && git -C nsrmp checkout "
            f"{ORIGINAL_COMMIT[:7]}` and pass --tree nsrmp")
NEEDED_MODULES = {"pybullet": "pybullet", "numpy": "numpy", "cv2": "opencv-python-headless",
                  "PIL": "pillow"}
"""What ``construct.py``'s imports need (module: the pip package that has it)."""

NO_PROGRAM = "NO compatible program found"
NOT_CONNECTED = "Not connected to physics server"
_PROGRESS = re.compile(  # what the original prints on its way (world.py, base.py, ...)
    r"^(Instruction no :|##### Found one program|\.+Requesting PyBullet|\.+Sample Deleted:"
    r"|\*+NO compatible program found|move_obj |pybullet build time:"
    r"|\d+ \d+ \(\d+, '\w+'\) (Small Cube|Dice|Lego)$|" + re.escape(NOT_CONNECTED) + ")")
_RUNPY_MARK = "bench_original_generator: runpy_s="
_SHIM_FLAG = "--shim-child"


class OriginalGeneratorError(RuntimeError):
    """The original generator cannot be run or produced nothing; the message says why and
    what to do."""


@dataclass(frozen=True)
class OriginalRun:
    """One run of the original generator."""

    wall_s: float
    """The child process, start to exit."""
    cpu_s: float
    """Its user + system CPU seconds (about ``wall_s`` on a quiet machine; well below it
    where another process shared the core)."""
    runpy_s: float | None
    """Seconds inside ``construct.py`` (no interpreter start, no shim imports)."""
    scenes: int
    sample_dirs: int
    samples: int
    """Sample folders with a ``demo.json`` (the §7.4 "with demo.json")."""
    languages: tuple[str, ...]
    """The demo.jsons' ``language_complexity`` values (``complex`` draws one per run)."""
    no_program: int
    other_messages: tuple[tuple[str, int], ...]
    """The child's output lines that are neither progress nor expected, with counts."""
    dataset: Path | None
    """Where the dataset was kept (``keep``), else None (removed)."""

    @property
    def seconds_per_sample(self) -> float:
        """Wall seconds per sample with a demo.json (§7.4)."""
        return self.wall_s / self.samples


def data_generation_dir(tree: Path, template: str = "SingleStep") -> Path:
    """The tree's ``data_generation`` folder, after checking it is the original's layout
    and has ``template``; raises :class:`OriginalGeneratorError` saying what is wrong."""
    tree = Path(tree)
    if not tree.is_dir():
        what = "is a file" if tree.exists() else "does not exist"
        msg = (
            f"--tree {tree} {what}; expected the root of the original NSRMP repository "
            f"(dair-iitd/nsrmp at {ORIGINAL_COMMIT[:7]}): {GET_TREE}")
        raise OriginalGeneratorError(msg)
    dg = tree / "data_generation"
    needed = ["construct.py", "configs.py", "manage.py", "panda/construct/program_generator.py",
              "panda/construct/metadata.json"]
    missing = [n for n in needed if not (dg / n).is_file()]
    if missing:
        msg = (
            f"--tree {tree} is not the original NSRMP repository's layout: "
            f"{', '.join('data_generation/' + m for m in missing)} missing; expected the "
            f"root of dair-iitd/nsrmp at {ORIGINAL_COMMIT[:7]} (the folder that holds "
            f"data_generation/): {GET_TREE}")
        raise OriginalGeneratorError(msg)
    templates = dg / "panda" / "construct" / "templates"
    if not (templates / f"{template}.json").is_file():
        have = sorted(p.stem for p in templates.glob("*.json"))
        msg = (
            f"--template {template}: no {templates / (template + '.json')}; expected one of "
            f"{', '.join(have) or '(none: the templates folder is empty or missing)'}")
        raise OriginalGeneratorError(msg)
    return dg


def check_modules() -> None:
    """Raises :class:`OriginalGeneratorError` naming the modules ``construct.py`` needs
    that this interpreter (the child's) lacks, with the ``pip install`` that adds them."""
    missing = [m for m in NEEDED_MODULES if importlib.util.find_spec(m) is None]
    if missing:
        msg = (
            f"the original generator needs the module(s) {', '.join(missing)}, which "
            f"{sys.executable} cannot import: `{sys.executable} -m pip install "
            f"{' '.join(NEEDED_MODULES[m] for m in missing)}`")
        raise OriginalGeneratorError(msg)


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
        raise OriginalGeneratorError(msg)
    return core


def _tail(text: str, lines: int = 25) -> str:
    return "\n".join(text.rstrip().splitlines()[-lines:])


def original_seconds_per_sample(
        tree: Path, *, scenes: int, seed: int, template: str = "SingleStep", objects: int = 5,
        language: str = "simple", object_type: str = "any", width: int = 1024,
        height: int = 768, core: int | None = None, keep: Path | None = None) -> OriginalRun:
    """Runs the original generator once (see the module doc) and times it.

    ``keep``: a folder that must not exist yet; the dataset and the child's output
    (``output.log``) are left there instead of being removed.
    Raises :class:`OriginalGeneratorError` for a bad tree, template, value, core or a
    missing module, and when the child fails or writes no sample with a demo.json.
    """
    dg = data_generation_dir(tree, template)
    if scenes < 1 or objects < 1 or width < 1 or height < 1:
        msg = (
            f"scenes={scenes}, objects={objects}, width={width}, height={height}: each "
            "must be at least 1")
        raise OriginalGeneratorError(msg)
    if language not in ("simple", "complex") or object_type not in ("any", "cube"):
        msg = (
            f"language={language!r}, type={object_type!r}: expected language 'simple' or "
            "'complex' (complex draws complex or compound per run, §3.4) and type 'any' or "
            "'cube' (construct.py's only two)")
        raise OriginalGeneratorError(msg)
    check_modules()
    pin = pick_core(core)
    if keep is not None:
        keep = Path(keep).resolve()
        if keep.exists():
            msg = (
                f"--keep {keep} exists; the original numbers samples by the folder's entry "
                "count, so it needs a new folder: pass a path that does not exist yet")
            raise OriginalGeneratorError(msg)
        keep.mkdir(parents=True)
        work = keep
    else:
        work = Path(tempfile.mkdtemp(prefix="nsrmp-original-"))
    dataset = work / "dataset"  # construct.py makes it (os.mkdir)
    construct_args = [
        "--template_file", f"./panda/construct/templates/{template}.json",
        "--metadata_file", "./panda/construct/metadata.json",
        "--dataset_dir", str(dataset), "--type", object_type, "--max_objects", str(objects),
        "--language", language, "--num_examples", str(scenes)]
    if (width, height) != (1024, 768):
        construct_args += ["--width", str(width), "--height", str(height)]
    cmd = [sys.executable, str(Path(__file__).resolve()), _SHIM_FLAG, str(dg), str(seed),
           *construct_args]
    env = {**os.environ, "PYTHONBREAKPOINT": "0", "PYTHONHASHSEED": "0",
           "PYTHONUNBUFFERED": "1"}
    log = work / "output.log"
    try:
        with log.open("wb") as out:
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            proc = subprocess.run(
                cmd, cwd=dg, env=env, stdin=subprocess.DEVNULL, stdout=out,
                stderr=subprocess.STDOUT, check=False,
                preexec_fn=None if pin is None else (lambda: os.sched_setaffinity(0, {pin})))
            wall = time.perf_counter() - start
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
        text = log.read_text(errors="replace")
        dirs = [d for d in dataset.iterdir() if d.is_dir()] if dataset.is_dir() else []
        demos = [d / "demo.json" for d in dirs if (d / "demo.json").is_file()]
        samples = len(demos)
        drawn = sorted({str(json.loads(f.read_text()).get("language_complexity"))
                        for f in demos})
    finally:
        if keep is None:
            shutil.rmtree(work, ignore_errors=True)
    missing_module = re.search(r"No module named '([^']+)'", text)
    if proc.returncode != 0 and missing_module:
        name = missing_module.group(1)
        msg = (
            f"the original generator needs the module {name}, which {sys.executable} cannot "
            f"import: `{sys.executable} -m pip install "
            f"{NEEDED_MODULES.get(name.split('.')[0], name.split('.')[0])}`")
        raise OriginalGeneratorError(msg)
    if proc.returncode != 0 or samples == 0:
        why = (f"exited with code {proc.returncode}" if proc.returncode != 0
               else f"wrote no sample with a demo.json ({len(dirs)} sample folders)")
        msg = (
            f"the original generator ({dg / 'construct.py'}, {template}, {objects} objects, "
            f"{language}, {scenes} scenes) {why}; the end of its output:\n{_tail(text)}")
        raise OriginalGeneratorError(msg)
    runpy_s = None
    other: collections.Counter[str] = collections.Counter()
    for line in text.splitlines():
        line = line.strip()
        if line.startswith(_RUNPY_MARK):
            runpy_s = float(line[len(_RUNPY_MARK):])
        elif line and not _PROGRESS.match(line):
            other[line[:160]] += 1
    return OriginalRun(
        wall_s=wall,
        cpu_s=(after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime),
        runpy_s=runpy_s, scenes=scenes, sample_dirs=len(dirs), samples=samples,
        languages=tuple(drawn), no_program=text.count(NO_PROGRAM),
        other_messages=tuple(other.most_common()),
        dataset=dataset if keep is not None else None)


def _shim_child(argv: list[str]) -> None:
    """The child: patch PyBullet (module doc, 1-3), seed, run construct.py as __main__.
    ``argv``: the data_generation folder, the seed, then construct.py's arguments."""
    dg, seed, construct_args = argv[0], int(argv[1]), argv[2:]
    import random
    import runpy

    import numpy as np
    import pybullet as p

    real_connect = p.connect
    real_camera_image = p.getCameraImage
    camera: dict[str, Any] = {}

    def connect(method: int, *args: Any, **kwargs: Any) -> int:
        if method == p.GUI:
            return int(real_connect(p.DIRECT))
        return int(real_connect(method, *args, **kwargs))

    def reset_debug_visualizer_camera(cameraDistance: float, cameraYaw: float,
                                      cameraPitch: float, cameraTargetPosition: Sequence[float],
                                      **_: Any) -> None:
        camera.update(distance=cameraDistance, yaw=cameraYaw, pitch=cameraPitch,
                      target=list(cameraTargetPosition))

    def get_camera_image(width: int, height: int, viewMatrix: Any = None,
                         projectionMatrix: Any = None, **kwargs: Any) -> Any:
        w, h = int(width), int(height)
        if viewMatrix is None and projectionMatrix is None:
            if not camera:
                msg = "getCameraImage without matrices before resetDebugVisualizerCamera"
                raise RuntimeError(msg)
            viewMatrix = p.computeViewMatrixFromYawPitchRoll(
                camera["target"], camera["distance"], camera["yaw"], camera["pitch"], 0, 2)
            a = w / h
            projectionMatrix = p.computeProjectionMatrix(-a * 0.01, a * 0.01, -0.01, 0.01,
                                                         0.01, 1000)
            kwargs.setdefault("renderer", p.ER_TINY_RENDERER)
        return real_camera_image(w, h, viewMatrix, projectionMatrix, **kwargs)

    p.connect = connect
    p.resetDebugVisualizerCamera = reset_debug_visualizer_camera
    p.getCameraImage = get_camera_image

    os.chdir(dg)
    sys.path[0] = dg  # as `python construct.py` run from data_generation
    script = os.path.join(dg, "construct.py")
    sys.argv = [script, *construct_args]
    random.seed(seed)
    np.random.seed(seed)
    start = time.perf_counter()
    try:
        runpy.run_path(script, run_name="__main__")
    finally:
        print(f"{_RUNPY_MARK}{time.perf_counter() - start:.3f}", file=sys.stderr, flush=True)


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.2f} (1 min), {five:.2f} (5 min)"


def main(argv: Sequence[str] | None = None) -> int:
    args_in = list(sys.argv[1:] if argv is None else argv)
    if args_in[:1] == [_SHIM_FLAG]:
        _shim_child(args_in[1:])
        return 0
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
                  f"construct.py {runpy_s} s), {run.scenes} scenes, {run.sample_dirs} sample "
                  f"dirs, {run.samples} with demo.json: {run.seconds_per_sample:.3f} s / "
                  f"sample; language {'/'.join(run.languages)}; {run.no_program} x no "
                  f"program; after, {_load()}")
            for message, count in run.other_messages[:8]:
                print(f"      {count:3d} x {message}")
            if run.dataset is not None:
                print(f"      kept: {run.dataset}")
    except OriginalGeneratorError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    med = statistics.median
    print(f"median of {len(runs)}: wall {med(r.wall_s for r in runs):.1f} s, "
          f"{med(r.samples for r in runs):g} samples with demo.json, "
          f"{med(r.seconds_per_sample for r in runs):.3f} s / sample (wall), "
          f"{med(r.cpu_s / r.samples for r in runs):.3f} s / sample (CPU)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
