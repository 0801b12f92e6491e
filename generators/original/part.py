"""A TEST part made by the original authors' generator, imported as an ordinary part.

:func:`make_original_part` is two stages:

1. :func:`stage_original` checks the tree is the pinned commit, runs ``construct.py``
   through the shim once per entry of a plan (:func:`plan_runs`: each template file with
   each language it has text for, object counts cycling over ``objects``), keeps the first
   examples of each run in its order, in the original's own layout, and writes
   :data:`PINS_NAME`: what was run (:func:`pins`: the commit, each run's command line and
   seed, the templates, the number of examples, the image size, the camera preset, the
   shim's version, PyBullet's and Python's versions);
2. :func:`import_staged` imports that folder with
   :func:`nsrmp_bench.storage.nsrm_import.import_nsrm`, the pins becoming the manifest's
   ``versions``. A staged folder needs no tree: the committed test fixture is one.

Randomness: the original seeds nothing; run ``r``'s attempt ``a`` is seeded with
``SeedSequence([seed, r, a])``'s first 32-bit word (the shim seeds ``random`` and
``np.random`` with it; ``PYTHONHASHSEED=0``), so the part is a function of the arguments.
"""

from __future__ import annotations

import json
import math
import platform
import shutil
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any, Final

import numpy as np

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.errors import GenerationError, InvalidArgument
from nsrmp_bench.storage.nsrm_import import ImportReport, import_nsrm

from .run import DEFAULT_SIZE, OriginalRun, RunSpec, run_original
from .shim import SHIM_VERSION
from .tree import ORIGINAL_COMMIT, ORIGINAL_REPOSITORY, check_modules, check_pinned

__all__ = [
    "CAMERA_PRESET",
    "DEFAULT_OBJECTS",
    "DEFAULT_TEMPLATES",
    "MAX_ATTEMPTS",
    "PINS_NAME",
    "PartReport",
    "PlannedRun",
    "import_staged",
    "make_original_part",
    "pins",
    "plan_runs",
    "read_pins",
    "run_seed",
    "stage_original",
]

DEFAULT_TEMPLATES: Final = ("SingleStep", "DoubleStep", "RelationalSingleStep",
                            "RelationalDoubleStep", "RelationalDoubleStepCornerCases")
"""Every template file of the pinned commit."""
DEFAULT_OBJECTS: Final = (3, 4, 5)
"""The object counts the paper trains on (``--max_objects`` is the exact count)."""
CAMERA_PRESET: Final = "big_table_view_2"
"""The preset the pinned ``construct.py`` sets (its line 85); the shim renders through it."""
MAX_ATTEMPTS: Final = 6
"""Runs per plan entry before giving up (a run loses examples when no program is found or
a template lacks text for the language drawn)."""
EXAMPLES_PER_SCENE: Final = 3
"""``configs.num_instruction_per_scene``: examples per ``--num_examples`` scene, at most."""
DATASET_PLACEHOLDER: Final = "DATASET"
PINS_NAME: Final = "original-pins.json"
"""The file of a staging folder that holds what was run (the manifest's ``versions``)."""


@dataclass(frozen=True)
class PlannedRun:
    """One entry of the plan: a ``construct.py`` setting and how many examples it gives."""

    name: str
    template: str
    language: str
    objects: int
    examples: int


def _template_file(dg: Path, template: str) -> tuple[tuple[str, ...], int]:
    """The languages a template file has text for (``simple``, and ``complex`` where some
    template of the file has both complex and compound text: ``construct.py --language
    complex`` draws one of them per run) and the fewest objects every template of the file
    can be grounded in (its largest ``num_unique_objects``)."""
    path = dg / "panda" / "construct" / "templates" / f"{template}.json"
    try:
        entries: list[dict[str, Any]] = json.loads(path.read_text("utf-8"))
        rich = any(t.get("text", {}).get("complex") and t.get("text", {}).get("compound")
                   for t in entries)
        least = max(int(t["num_unique_objects"]) for t in entries)
    except (OSError, ValueError, AttributeError, KeyError, TypeError) as exc:
        msg = f"{path} is not the original's template file ({exc!r}); check out the tree again"
        raise InvalidArgument(msg) from exc
    return ("simple", "complex") if rich else ("simple",), least


def plan_runs(dg: Path, examples: int, templates: Sequence[str],
              objects: Sequence[int]) -> list[PlannedRun]:
    """The runs: each template file with each of its languages, the object count cycling
    over those of ``objects`` the file's templates can be grounded in, ``examples`` split as
    evenly as possible (earlier runs get the rest)."""
    if examples < 1:
        msg = f"--examples {examples}: expected at least 1"
        raise InvalidArgument(msg)
    if not templates or not objects or any(n < 2 for n in objects):
        msg = (f"templates={list(templates)}, objects={list(objects)}: expected at least one "
               "template and object counts of at least 2 (a move needs two objects)")
        raise InvalidArgument(msg)
    settings: list[tuple[str, str, list[int]]] = []
    for t in templates:
        languages, least = _template_file(dg, t)
        counts = [n for n in objects if n >= least]
        if not counts:
            msg = (f"--objects {','.join(map(str, objects))}: template file {t} needs at least "
                   f"{least} objects (its num_unique_objects); add a count of {least} or more")
            raise InvalidArgument(msg)
        settings.extend((t, lang, counts) for lang in languages)
    if examples < len(settings):
        settings = settings[:examples]
    base, extra = divmod(examples, len(settings))
    out = []
    for r, (template, lang, counts) in enumerate(settings):
        n_obj = counts[r % len(counts)]
        out.append(PlannedRun(f"r{r:02d}-{template}-{lang}-o{n_obj}", template, lang, n_obj,
                              base + (r < extra)))
    return out


def run_seed(seed: int, run: int, attempt: int) -> int:
    """The seed the shim gets for run ``run``'s attempt ``attempt``."""
    return int(np.random.SeedSequence([seed, run, attempt]).generate_state(1)[0])


@dataclass(frozen=True)
class PartReport:
    """What :func:`make_original_part` did."""

    imported: ImportReport
    runs: tuple[tuple[PlannedRun, tuple[OriginalRun, ...]], ...]
    """Each planned run with the runs of the original it took."""


def _command(run: OriginalRun) -> str:
    """The run's command line, free of local paths."""
    _, _, seed, *args = run.command
    args[args.index("--dataset_dir") + 1] = DATASET_PLACEHOLDER
    return " ".join(["python", "shim.py", "data_generation", seed, *args])


def pins(runs: Sequence[tuple[PlannedRun, Sequence[OriginalRun]]], *, seed: int,
         examples: int, templates: Sequence[str], size: tuple[int, int]) -> dict[str, str]:
    """The manifest's ``versions``: what was run, so that it can be run again."""
    rows = [{"run": p.name, "template": p.template, "language": p.language,
             "objects": p.objects, "examples": p.examples,
             "attempts": [{"seed": r.spec.seed, "scenes": r.spec.scenes,
                           "examples_written": len(r.samples), "drawn": list(r.languages),
                           "command": _command(r)} for r in rs]}
            for p, rs in runs]
    return {
        "original": f"{ORIGINAL_REPOSITORY}@{ORIGINAL_COMMIT} data_generation/construct.py, "
                    "unmodified",
        "original_commit": ORIGINAL_COMMIT,
        "original_runs": canonical_json(rows),
        "seed": str(seed),
        "examples": str(examples),
        "templates": ",".join(templates),
        "image_size": f"{size[0]}x{size[1]}",
        "camera": CAMERA_PRESET,
        "shim": SHIM_VERSION,
        "pybullet": metadata.version("pybullet"),
        "python": platform.python_version(),
        "split_role": "test only: nothing trains or selects on it",
    }


def stage_original(
    tree: str | Path,
    stage: str | Path,
    *,
    examples: int,
    seed: int,
    templates: Sequence[str] = DEFAULT_TEMPLATES,
    objects: Sequence[int] = DEFAULT_OBJECTS,
    size: tuple[int, int] = DEFAULT_SIZE,
    progress: Callable[[PlannedRun, OriginalRun], None] | None = None,
) -> tuple[tuple[PlannedRun, tuple[OriginalRun, ...]], ...]:
    """Run the original generator (pinned tree, through the shim) per the plan into
    ``stage`` (a new folder): ``stage/<run>/NNNN`` in the original's own layout, plus
    :data:`PINS_NAME`, what was run. The runs' own folders and logs stay beside it, in
    ``stage.parent / "runs"``. Raises :class:`InvalidArgument` for a bad tree or value,
    :class:`GenerationError` when a run keeps giving too few examples, and
    :class:`MissingExtra` (first of all) when a module the original imports is missing."""
    check_modules()
    dg = check_pinned(tree)
    stage = Path(stage)
    if stage.exists():
        msg = f"{stage} exists; give a folder that does not exist yet"
        raise InvalidArgument(msg)
    plan = plan_runs(dg, examples, templates, objects)
    stage.mkdir(parents=True)
    done = []
    for r, planned in enumerate(plan):
        kept = _run_planned(tree, stage.parent / "runs", stage, r, planned, seed, size,
                            progress)
        done.append((planned, tuple(kept)))
    pinned = pins(done, seed=seed, examples=examples, templates=templates, size=size)
    (stage / PINS_NAME).write_text(json.dumps(pinned, indent=1, sort_keys=True) + "\n")
    return tuple(done)


def read_pins(stage: str | Path) -> dict[str, str]:
    """The pins :func:`stage_original` wrote into ``stage``, checked to name the pinned
    commit, the shim and the camera."""
    path = Path(stage) / PINS_NAME
    try:
        pinned = json.loads(path.read_text("utf-8"))
    except (OSError, ValueError) as exc:
        msg = (f"{path} is missing or not JSON ({exc}); give a folder staged by "
               "`nsrmp-bench import-original --work DIR` (its examples/ folder)")
        raise InvalidArgument(msg) from exc
    if not isinstance(pinned, dict) or not all(isinstance(v, str) for v in pinned.values()):
        msg = f"{path}: expected an object of strings (the manifest's versions)"
        raise InvalidArgument(msg)
    problems = [f"{k}={pinned.get(k)!r} (expected {want!r})"
                for k, want in (("original_commit", ORIGINAL_COMMIT), ("shim", SHIM_VERSION),
                                ("camera", CAMERA_PRESET)) if pinned.get(k) != want]
    if problems:
        msg = (f"{path}: {', '.join(problems)}; this staging was not made by this version's "
               f"runner of {ORIGINAL_REPOSITORY} at {ORIGINAL_COMMIT[:7]}: stage it again")
        raise InvalidArgument(msg)
    return {str(k): v for k, v in pinned.items()}


def _check_new_or_empty(out: str | Path) -> None:
    out = Path(out)
    if out.exists() and any(out.iterdir()):
        msg = (f"--out {out} is not empty; the part is written whole: remove it or give a new "
               "folder")
        raise InvalidArgument(msg)


def import_staged(stage: str | Path, out: str | Path, *, split: str = "original-v1/test",
                  shard_size: int = 1000) -> ImportReport:
    """Import a folder made by :func:`stage_original` as the part ``out`` (new or empty),
    its manifest's ``versions`` holding the pins."""
    pinned = read_pins(stage)
    _check_new_or_empty(out)
    report = import_nsrm(stage, out, split=split, shard_size=shard_size,
                         camera=pinned["camera"], versions=pinned)
    if report.imported != int(pinned.get("examples", -1)) or report.skipped:
        msg = (f"{stage}: {report.imported} examples imported ({len(report.skipped)} without "
               f"demo.json), but the pins say {pinned.get('examples')}; stage it again")
        raise GenerationError(msg)
    return report


def make_original_part(
    tree: str | Path,
    out: str | Path,
    *,
    examples: int,
    seed: int,
    templates: Sequence[str] = DEFAULT_TEMPLATES,
    objects: Sequence[int] = DEFAULT_OBJECTS,
    size: tuple[int, int] = DEFAULT_SIZE,
    split: str = "original-v1/test",
    shard_size: int = 1000,
    work: str | Path | None = None,
    progress: Callable[[PlannedRun, OriginalRun], None] | None = None,
) -> PartReport:
    """:func:`stage_original` then :func:`import_staged`: the original generator's
    examples as the part ``out``. ``work``: keep the staging (``work/examples``) and the
    runs' folders and logs (``work/runs``) there (a new folder) instead of a temporary
    one."""
    _check_new_or_empty(out)
    if work is not None and Path(work).exists():
        msg = f"--work {work} exists; give a folder that does not exist yet"
        raise InvalidArgument(msg)
    with tempfile.TemporaryDirectory(prefix="nsrm-original-") as tmp:
        root = Path(work) if work is not None else Path(tmp)
        done = stage_original(tree, root / "examples", examples=examples, seed=seed,
                              templates=templates, objects=objects, size=size,
                              progress=progress)
        report = import_staged(root / "examples", out, split=split, shard_size=shard_size)
    return PartReport(report, done)


def _run_planned(tree: str | Path, runs: Path, stage: Path, r: int, planned: PlannedRun,
                 seed: int, size: tuple[int, int],
                 progress: Callable[[PlannedRun, OriginalRun], None] | None,
                 ) -> list[OriginalRun]:
    """Run ``planned`` until it has its examples; move them to ``stage/<name>/NNNN``."""
    target = stage / planned.name
    target.mkdir()
    have: list[Path] = []
    done: list[OriginalRun] = []
    for attempt in range(MAX_ATTEMPTS):
        need = planned.examples - len(have)
        spec = RunSpec(planned.template, planned.objects, planned.language,
                       scenes=math.ceil(need / EXAMPLES_PER_SCENE) + 1,
                       seed=run_seed(seed, r, attempt), width=size[0], height=size[1])
        run = run_original(tree, runs / f"{planned.name}-a{attempt}", spec, allow_empty=True)
        done.append(run)
        if progress is not None:
            progress(planned, run)
        have.extend(run.dataset / name for name in run.samples[:need])
        if len(have) == planned.examples:
            break
    else:
        msg = (
            f"run {planned.name}: {MAX_ATTEMPTS} runs of the original gave {len(have)} of the "
            f"{planned.examples} examples asked for (rerun with --work DIR to keep their logs); "
            "ask for fewer examples, or leave this template or object count out")
        raise GenerationError(msg)
    for i, folder in enumerate(have):
        shutil.move(str(folder), str(target / f"{i:04d}"))
    return done
