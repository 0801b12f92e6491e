"""One run of the original generator (``construct.py`` through :mod:`.shim`) into a folder.

A run is one ``construct.py`` process: one template file, one language setting, one object
count, ``scenes`` scenes (``--num_examples``; up to 3 examples each). The child process is
``python shim.py DATA_GENERATION SEED ARGS`` with ``PYTHONHASHSEED=0`` and
``PYTHONBREAKPOINT=0`` (the latter disarms the ``breakpoint()`` left at
``program_generator.py:130``, which then raises as it would after ``continue``); its output
goes to a log beside the dataset.
"""

from __future__ import annotations

import collections
import json
import os
import re
import resource
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Final

from nsrmp_bench.errors import GenerationError, InvalidArgument, MissingExtra

from . import shim
from .tree import NEEDED_MODULES, check_modules, data_generation_dir

__all__ = ["LANGUAGES", "OBJECT_TYPES", "OriginalRun", "RunSpec", "run_original"]

LANGUAGES: Final = ("simple", "complex")
"""``construct.py --language``: ``complex`` draws complex or compound once per process."""
OBJECT_TYPES: Final = ("any", "cube")
"""``construct.py --type``: its only two."""
DEFAULT_SIZE: Final = (1024, 768)
"""The original's own image size; other sizes are passed as ``--width/--height``."""

NO_PROGRAM: Final = "NO compatible program found"
NOT_CONNECTED: Final = "Not connected to physics server"
_PROGRESS: Final = re.compile(  # what the original prints on its way (world.py, base.py, ...)
    r"^(Instruction no :|##### Found one program|\.+Requesting PyBullet|\.+Sample Deleted:"
    r"|\*+NO compatible program found|move_obj |pybullet build time:"
    r"|\d+ \d+ \(\d+, '\w+'\) (Small Cube|Dice|Lego)$|" + re.escape(NOT_CONNECTED) + ")")


@dataclass(frozen=True)
class RunSpec:
    """What one ``construct.py`` process is asked for."""

    template: str
    """A file of ``data_generation/panda/construct/templates/``, without ``.json``."""
    objects: int
    """``--max_objects`` (the exact object count)."""
    language: str
    scenes: int
    seed: int
    object_type: str = "any"
    width: int = DEFAULT_SIZE[0]
    height: int = DEFAULT_SIZE[1]

    def check(self) -> None:
        """Raises :class:`InvalidArgument` naming a value ``construct.py`` cannot take."""
        if self.scenes < 1 or self.objects < 1 or self.width < 1 or self.height < 1:
            msg = (
                f"scenes={self.scenes}, objects={self.objects}, width={self.width}, "
                f"height={self.height}: each must be at least 1")
            raise InvalidArgument(msg)
        if self.language not in LANGUAGES or self.object_type not in OBJECT_TYPES:
            msg = (
                f"language={self.language!r}, type={self.object_type!r}: expected language "
                f"one of {LANGUAGES} (complex draws complex or compound per run) and type one "
                f"of {OBJECT_TYPES} (construct.py's only two)")
            raise InvalidArgument(msg)
        if self.seed < 0:
            msg = f"seed={self.seed}: expected a non-negative integer"
            raise InvalidArgument(msg)

    def construct_args(self, dataset: Path) -> list[str]:
        """``construct.py``'s command line (paths relative to ``data_generation``)."""
        args = [
            "--template_file", f"./panda/construct/templates/{self.template}.json",
            "--metadata_file", "./panda/construct/metadata.json",
            "--dataset_dir", str(dataset), "--type", self.object_type,
            "--max_objects", str(self.objects), "--language", self.language,
            "--num_examples", str(self.scenes)]
        if (self.width, self.height) != DEFAULT_SIZE:
            args += ["--width", str(self.width), "--height", str(self.height)]
        return args


@dataclass(frozen=True)
class OriginalRun:
    """What one run did."""

    spec: RunSpec
    dataset: Path
    """The folder ``construct.py`` made (one ``NNNN`` folder per example)."""
    command: tuple[str, ...]
    """The child's command line after the interpreter: shim, data_generation folder, seed,
    then ``construct.py``'s arguments (the dataset folder as given)."""
    wall_s: float
    """The child process, start to exit."""
    cpu_s: float
    """Its user + system CPU seconds."""
    runpy_s: float | None
    """Seconds inside ``construct.py`` (no interpreter start, no shim imports)."""
    sample_dirs: int
    samples: tuple[str, ...]
    """Names of the example folders with a ``demo.json``, sorted."""
    languages: tuple[str, ...]
    """The demo.jsons' ``language_complexity`` values."""
    no_program: int
    other_messages: tuple[tuple[str, int], ...]
    """The child's output lines that are neither progress nor expected, with counts."""

    @property
    def seconds_per_sample(self) -> float:
        """Wall seconds per example with a demo.json."""
        return self.wall_s / max(len(self.samples), 1)


def _tail(text: str, lines: int = 25) -> str:
    return "\n".join(text.rstrip().splitlines()[-lines:])


def run_original(tree: str | Path, dataset: Path, spec: RunSpec, *, core: int | None = None,
                 allow_empty: bool = False) -> OriginalRun:
    """Run the original generator once into ``dataset`` (which must not exist: the original
    numbers examples by the folder's entry count); its output goes to
    ``dataset.parent / (dataset.name + ".log")``. ``core``: pin the child to that core.

    Raises :class:`InvalidArgument` for a bad tree or value, :class:`MissingExtra` for a
    missing module, :class:`GenerationError` when the child fails or (unless
    ``allow_empty``) writes no example with a demo.json.
    """
    spec.check()
    dg = data_generation_dir(tree, spec.template)
    check_modules()
    dataset = Path(dataset).resolve()
    if dataset.exists():
        msg = (
            f"{dataset} exists; the original numbers examples by the folder's entry count, "
            "so it needs a new folder: pass a path that does not exist yet")
        raise InvalidArgument(msg)
    dataset.parent.mkdir(parents=True, exist_ok=True)
    command = (str(Path(shim.__file__).resolve()), str(dg), str(spec.seed),
               *spec.construct_args(dataset))
    env = {**os.environ, "PYTHONBREAKPOINT": "0", "PYTHONHASHSEED": "0",
           "PYTHONUNBUFFERED": "1"}
    log = dataset.parent / (dataset.name + ".log")
    with log.open("wb") as out:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, *command], cwd=dg, env=env, stdin=subprocess.DEVNULL, stdout=out,
            stderr=subprocess.STDOUT, check=False,
            preexec_fn=None if core is None else (lambda: os.sched_setaffinity(0, {core})))
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    text = log.read_text(errors="replace")
    dirs = sorted(d for d in dataset.iterdir() if d.is_dir()) if dataset.is_dir() else []
    demos = [d for d in dirs if (d / "demo.json").is_file()]
    drawn = sorted({str(json.loads((d / "demo.json").read_text()).get("language_complexity"))
                    for d in demos})
    missing_module = re.search(r"No module named '([^']+)'", text)
    if proc.returncode != 0 and missing_module:
        name = missing_module.group(1).split(".")[0]
        msg = (
            f"the original generator needs the module {name}, which {sys.executable} cannot "
            f"import: `{sys.executable} -m pip install {NEEDED_MODULES.get(name, name)}`")
        raise MissingExtra(msg)
    if proc.returncode != 0 or (not demos and not allow_empty):
        why = (f"exited with code {proc.returncode}" if proc.returncode != 0
               else f"wrote no sample with a demo.json ({len(dirs)} sample folders)")
        msg = (
            f"the original generator ({dg / 'construct.py'}, {spec.template}, {spec.objects} "
            f"objects, {spec.language}, {spec.scenes} scenes) {why}; the end of its output "
            f"({log}):\n{_tail(text)}")
        raise GenerationError(msg)
    runpy_s = None
    other: collections.Counter[str] = collections.Counter()
    for line in text.splitlines():
        line = line.strip()
        if line.startswith(shim.RUNPY_MARK):
            runpy_s = float(line[len(shim.RUNPY_MARK):])
        elif line and not _PROGRESS.match(line):
            other[line[:160]] += 1
    return OriginalRun(
        spec=spec, dataset=dataset, command=command, wall_s=wall,
        cpu_s=(after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime),
        runpy_s=runpy_s, sample_dirs=len(dirs), samples=tuple(d.name for d in demos),
        languages=tuple(drawn), no_program=text.count(NO_PROGRAM),
        other_messages=tuple(other.most_common()))
