"""Evaluating models and predictions files on every official test part in one go.

A *source* is a learned model id (``nsrm``, ``nsrm-v3``: it is run with ``predict``), a
baseline id (``oracle``, ``noop``, ``random``: written like ``nsrmp-bench baseline``), or a
predictions file (scored on the split part its header names). Model and baseline sources
are run on every official test part found under the data root; ``generate=True`` first
generates the official test parts that are missing.

A part ``paper-v2/test`` is looked for at ``ROOT/paper-v2/test``, then at ``ROOT/paper/test``
(the short folder names the README uses). The output folder gets ``summary.json`` (read by
``plot``, ``report`` and the web leaderboard), one CSV per split part with every figure and
category group of every run, and the predictions files the models and baselines wrote
(``predictions/``).

Each run (one source on one split part: predict or baseline, then score) is one task handed
to an engine (``nsrmp_bench.engine``: this process, a local process pool or a Dask
cluster); results come back in the order of the runs, so the outputs do not depend on the
engine.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from nsrmp_bench.baselines.registry import BASELINES, run_baseline
from nsrmp_bench.engine import Engine, InlineEngine, TaskReport, in_task_order
from nsrmp_bench.errors import InvalidArgument, UnknownId
from nsrmp_bench.predictors import refuse_retired
from nsrmp_bench.results.summary import Results, Run
from nsrmp_bench.scoring.gold import load_episodes
from nsrmp_bench.scoring.reader import read_submission_pending
from nsrmp_bench.scoring.result import ScoreResult
from nsrmp_bench.scoring.scorer import score
from nsrmp_bench.split_specs import OFFICIAL_SPLITS, list_splits, load_split
from nsrmp_bench.storage.split_root import find_part, split_root_parts

__all__ = [
    "GeneratePart", "Job", "PredictPart", "Runners", "Source", "evaluate", "evaluate_job",
    "find_part", "long_table", "official_test_parts", "resolve_source",
]

Say = Callable[[str], None]


@dataclass(frozen=True)
class Source:
    """What to evaluate: ``kind`` is ``model``, ``baseline`` or ``file``."""

    kind: str
    name: str
    path: Path | None = None


PredictPart = Callable[[str, Path, Path], object]
"""Runs a learned model over a part into a predictions file: (model id, data, out)."""
GeneratePart = Callable[[str, str, Path, int, "Engine | None"], object]
"""Generates a split's part: (split id, part, out, workers, engine)."""


@dataclass(frozen=True)
class Runners:
    """What the core does not import but an evaluation may run, passed in by the caller
    (the command line): the learned models' ids and how to run one, and the generator."""

    models: tuple[str, ...] = ()
    predict: PredictPart | None = None
    generate: GeneratePart | None = None


def resolve_source(text: str, models: Sequence[str] = ()) -> Source:
    """A model id (of ``models``), a baseline id or a predictions file; a retired model's id
    says which release runs it, anything else names all three."""
    path = Path(text)
    if path.suffix in {".jsonl", ".gz", ".parquet"} or path.exists():
        if not path.is_file():
            msg = (f"predictions file {text!r} does not exist; pass a .jsonl/.jsonl.gz/"
                   ".parquet predictions file, a model id or a baseline id")
            raise InvalidArgument(msg)
        return Source("file", path.name, path)
    from nsrmp_bench.versioned_ids import resolve_id

    refuse_retired(text)  # its committed predictions files are still sources

    known_models = {m: m for m in models}
    for kind, known in (("baseline", BASELINES), ("model", known_models)):
        try:
            return Source(kind, resolve_id(text, known, kind))
        except UnknownId:
            continue
    msg = (f"{text!r} is neither a predictions file (.jsonl/.jsonl.gz/.parquet) nor a known id; "
           f"models: {', '.join(models)}; baselines: {', '.join(BASELINES)}")
    raise UnknownId(msg)


def official_test_parts() -> list[str]:
    """``<split id>/test`` for every official split that has a test part."""
    known = set(list_splits())
    return [f"{s}/test" for s in OFFICIAL_SPLITS
            if s in known and "test" in load_split(s).parts]


def _wanted_parts(splits: Sequence[str] | None) -> list[str]:
    official = official_test_parts()
    if splits is None:
        return official
    wanted = [f"{s}/test" for s in splits]
    unknown = [s for s, p in zip(splits, wanted, strict=True) if p not in official]
    if unknown:
        msg = (f"--splits {', '.join(unknown)}: not an official split with a test part; "
               f"choose from {', '.join(p.split('/')[0] for p in official)}")
        raise InvalidArgument(msg)
    return wanted


def _generate(root: Path, split_part: str, workers: int, engine: Engine | None,
              say: Say, generate: GeneratePart | None) -> Path:
    if generate is None:
        msg = "generate=True needs the generator: pass Runners(generate=...) (the CLI does)"
        raise InvalidArgument(msg)
    split_id, part = split_part.split("/", 1)
    load_split(split_id)
    out = root / split_id / part
    say(f"generating {split_part} into {out} ...")
    generate(split_id, part, out, workers, engine)
    return out


def _split_of_file(path: Path) -> tuple[str, str | None]:
    sub, _ = read_submission_pending(path)  # problems are reported when it is scored
    return sub.header.split, sub.header.model


def _relative(path: Path, folder: Path) -> str:
    return os.path.relpath(path.resolve(), folder.resolve())


def _stem(split_part: str) -> str:
    return split_part.replace("/", "-")


def long_table(model: str, result: ScoreResult) -> pd.DataFrame:
    """Every figure of one scored run as rows: ``all/all`` first, then each group."""
    overall = result.summary[["value", "ci_low", "ci_high", "n"]].reset_index()
    overall.insert(0, "group", "all")
    overall.insert(0, "category", "all")
    cols = ["category", "group", "metric", "value", "ci_low", "ci_high", "n"]
    table = pd.concat([overall[cols], result.per_category[cols]], ignore_index=True)
    table.insert(0, "model", model)
    return table


def evaluate(
    sources: Sequence[str | Source],
    data_root: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    generate: bool = False,
    splits: Sequence[str] | None = None,
    workers: int = 2,
    engine: Engine | None = None,
    say: Say | None = None,
    runners: Runners | None = None,
) -> Results:
    """Score every source on its parts; write ``summary.json`` and the CSVs into ``out``.

    ``splits`` (split ids) narrows the official test parts that models and baselines run on
    and that ``generate`` makes; predictions files are scored on their own part regardless.
    Each (source, part) run is one task for ``engine`` (entered by the caller; default:
    this process, and ``generate`` then uses a local pool of ``workers``). ``runners``
    brings what the core does not import: the learned models and the generator.
    """
    run_with = runners if runners is not None else Runners()
    tell: Say = say if say is not None else (lambda _line: None)
    root, folder = Path(data_root).resolve(), Path(out).resolve()
    resolved = [s if isinstance(s, Source) else resolve_source(s, run_with.models)
                for s in sources]
    if not resolved:
        msg = "nothing to evaluate: pass model ids, baseline ids or predictions files"
        raise InvalidArgument(msg)
    if not root.is_dir():
        msg = (f"--data-root {root} is not a directory; it should hold <split id>/<part>/ "
               "folders (nsrmp-bench generate --split paper-v2 --out ROOT/paper-v2)")
        raise InvalidArgument(msg)
    parts = {p: find_part(root, p) for p in _wanted_parts(splits)}
    if generate:
        parts = {p: d if d is not None else _generate(root, p, workers, engine, tell,
                                                             run_with.generate)
                 for p, d in parts.items()}
    found = {p: d for p, d in parts.items() if d is not None}
    jobs = [job for source in resolved
            for job in _jobs(source, found, root, folder, run_with.predict)]
    _refuse_twice_scored(jobs)
    (folder / "predictions").mkdir(parents=True, exist_ok=True)
    runs: list[Run] = []
    tables: dict[str, list[pd.DataFrame]] = {}
    with contextlib.ExitStack() as stack:
        if engine is None:
            engine = stack.enter_context(InlineEngine())
        if jobs:
            engine.require_shared_dir(root)
            engine.require_shared_dir(folder)
        tasks = [(job, str(folder)) for job in jobs]
        for job, (run, table, line) in zip(
                jobs, in_task_order(engine.map_unordered(evaluate_job, tasks)), strict=True):
            runs.append(run)
            tables.setdefault(job.split_part, []).append(table)
            tell(line)
    if not runs:
        held = split_root_parts(root)
        if held or (root / "manifest.json").is_file():
            what = (f"a split root (the parts {', '.join(held)} of one split)" if held
                    else "one part's data")
            msg = (f"--data-root {root} is {what}; --data-root is the folder above the "
                   "split roots, each named for its split (data/ holding data/smoke-v2/test/ "
                   f"or data/smoke/test/): pass {root.parent}")
            raise InvalidArgument(msg)
        msg = (f"no official test part under {root} (looked for "
               f"{', '.join(official_test_parts())} as ROOT/<split id>/<part>); generate "
               "them, or pass --generate")
        raise InvalidArgument(msg)
    results = Results(tuple(runs))
    results.write(folder)
    for split_part, frames in tables.items():
        pd.concat(frames, ignore_index=True).to_csv(folder / f"{_stem(split_part)}.csv",
                                                    index=False)
    return results


@dataclass(frozen=True)
class Job:
    """One run: ``source`` on ``split_part`` (data in ``data``, predictions in ``pred``)."""

    source: Source
    split_part: str
    data: Path
    pred: Path
    model: str
    kind: str
    predict: PredictPart | None = None  # runs a learned model (a module-level function)


def evaluate_job(job: Job, folder: str, *,
                 report: TaskReport | None = None) -> tuple[Run, pd.DataFrame, str]:
    """The task of one run: write the predictions (model or baseline), then score them.

    Returns the run, its long table and the line to print.
    """
    source = job.source
    if source.kind == "baseline":
        episodes, recorded = load_episodes(job.data)
        run_baseline(source.name, episodes, job.pred, split=recorded or job.split_part)
    elif source.kind == "model":
        if job.predict is None:
            msg = f"{source.name} is a learned model: pass Runners(predict=...) to run it"
            raise InvalidArgument(msg)
        job.predict(source.name, job.data, job.pred)
    result = score(job.pred, job.data, split=job.split_part)
    run = Run.from_score(result, model=job.model, kind=job.kind,
                         predictions=_relative(job.pred, Path(folder)))
    line = (f"{job.model} on {job.split_part}: IoU-M {result.headline:.3f} "
            f"(n={result.counts.get('instances', 0)})")
    if report is not None:
        report.advance()
    return run, long_table(job.model, result), line


def _refuse_twice_scored(jobs: Sequence[Job]) -> None:
    """Two runs of one model on one split part: refused before anything runs."""
    seen: dict[tuple[str, str], Job] = {}
    for job in jobs:
        first = seen.setdefault((job.model, job.split_part), job)
        if first is not job:
            msg = (f"{_what(first)} and {_what(job)} are both model {job.model!r} on "
                   f"{job.split_part}; a results folder holds one run per model and split "
                   "part: drop one, or give one its own name (`nsrmp-bench predict "
                   "--checkpoint ... --name NAME` writes it into the file's header)")
            raise InvalidArgument(msg)


def _what(job: Job) -> str:
    return str(job.source.path) if job.source.path is not None else repr(job.source.name)


def _jobs(source: Source, found: dict[str, Path], root: Path, folder: Path,
          predict: PredictPart | None) -> list[Job]:
    """Every run of ``source``: a file on its own part, an id on every part found."""
    if source.kind == "file" and source.path is not None:
        split_part, model = _split_of_file(source.path)
        data = found.get(split_part) or find_part(root, split_part)
        if data is None:
            split_id = split_part.split("/", 1)[0]
            msg = (f"{source.path} is for {split_part}, which is not under {root}; generate "
                   f"it: nsrmp-bench generate --split {split_id} --out {root / split_id}")
            raise InvalidArgument(msg)
        path = source.path.resolve()
        return [Job(Source("file", source.name, path), split_part, data, path,
                    model or source.path.stem, "submission")]
    if not found:
        return []
    kind = "baseline" if source.kind == "baseline" else "reference"
    return [Job(source, p, d, folder / "predictions" / f"{_stem(p)}--{source.name}.jsonl",
                source.name, kind, predict) for p, d in found.items()]
