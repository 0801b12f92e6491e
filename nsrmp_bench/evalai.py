"""An EvalAI challenge bundle: a public-test phase and a private-test phase scored by the
public scorer (``nsrmp-bench challenge --evalai OUT``).

The bundle (see ``docs/challenge.md``) is the folder EvalAI's "create a challenge from a
zip" takes, with what participants download beside it::

    OUT/challenge_config.yaml          title, dates, the leaderboard schema, two phases,
                                       their dataset splits and phase-split visibility
    OUT/evaluation_script/__init__.py  ``evaluate(test_annotation_file, user_submission_file,
    OUT/evaluation_script/main.py        phase_codename, **kwargs)``: EvalAI's entry point
    OUT/evaluation_script/phases.json  phase codename -> split codename, part, root hash
    OUT/evaluation_script/requirements.txt  nsrmp-bench pinned (by the wheel's sha256 with
                                       ``--wheel``), installed before the challenge opens:
                                       nothing is installed at evaluation time
    OUT/evaluation_script.zip          the same folder zipped (what the config names)
    OUT/annotations/<phase>.zip        each phase's gold part (manifest + shards): EvalAI
                                       keeps it on its workers, never shows it
    OUT/templates/*.html               the pages the config names
    OUT/participant_data/<split>/<part>/  each part packed inputs-only (no gold)

:func:`evaluate_phase` is what the bundled ``main.py`` calls: it unpacks the phase's gold
once per worker, checks the submission (``check-submission``, which refuses a file made
on another manifest) and scores it with :func:`nsrmp_bench.scoring.scorer.score` at its
defaults, returning EvalAI's result object whose numbers are exactly the scorer's:
each leaderboard column's value and its 95% interval.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import nsrmp_bench.errors as error_classes
from nsrmp_bench._optional import require
from nsrmp_bench._version import __version__
from nsrmp_bench.errors import (
    DataIntegrityError,
    InvalidArgument,
    NSRMPError,
    ResourceLimit,
    SubmissionError,
)
from nsrmp_bench.leaderboard import COLUMNS
from nsrmp_bench.release import pack
from nsrmp_bench.scoring.check import check_submission
from nsrmp_bench.scoring.metrics import METRICS_V2
from nsrmp_bench.scoring.result import ScoreResult
from nsrmp_bench.scoring.scorer import score
from nsrmp_bench.storage.contained import plain_name
from nsrmp_bench.storage.manifest import MANIFEST_NAME, Manifest, read_manifest

__all__ = [
    "EVALUATION_TIME_LIMIT_S",
    "PHASES_FILE",
    "PRIVATE_PHASE",
    "PUBLIC_PHASE",
    "ChallengePart",
    "evaluate_in_process",
    "evaluate_phase",
    "figures",
    "leaderboard_schema",
    "write_bundle",
]

PUBLIC_PHASE = "public-test"
PRIVATE_PHASE = "private-test"
PHASES_FILE = "phases.json"
REQUIREMENTS_FILE = "requirements.txt"
EVALUATION_TIME_LIMIT_S = 600.0
"""Seconds one evaluation may take before it is stopped (paper-v2/test scores in seconds)."""
_SPLIT_CODENAMES = {PUBLIC_PHASE: "public_test", PRIVATE_PHASE: "private_test"}
_LABELS = {m.name: m.label for m in METRICS_V2}
_HIGHER_IS_BETTER = True  # every leaderboard column is a score, IoU-M first


def _labels(metric: str) -> tuple[str, str, str]:
    """The leaderboard labels of a metric: its value and its interval's two ends."""
    label = _LABELS.get(metric, metric)
    return label, f"{label} 95% low", f"{label} 95% high"


def leaderboard_schema() -> dict[str, Any]:
    """EvalAI's leaderboard schema: the board's columns (headline IoU-M first), each with
    its 95% interval; ordered by IoU-M, higher first."""
    labels = [label for m in COLUMNS for label in _labels(m)]
    headline = _labels(COLUMNS[0])[0]
    metadata = {}
    for m in COLUMNS:
        value, low, high = _labels(m)
        metadata[value] = {"sort_ascending": not _HIGHER_IS_BETTER,
                           "description": f"{value} (scorer's value)"}
        metadata[low] = {"sort_ascending": not _HIGHER_IS_BETTER,
                         "description": f"lower end of {value}'s 95% bootstrap interval"}
        metadata[high] = {"sort_ascending": not _HIGHER_IS_BETTER,
                          "description": f"upper end of {value}'s 95% bootstrap interval"}
    return {"labels": labels, "default_order_by": headline, "metadata": metadata}


def figures(result: ScoreResult) -> dict[str, float]:
    """The scorer's figures under the leaderboard's labels; a metric the file cannot have
    (e.g. placement without pick and place points) is left out, as EvalAI stores numbers."""
    out: dict[str, float] = {}
    for m in COLUMNS:
        if m not in result.summary.index:
            continue
        value, (low, high) = result.value(m), result.interval(m)
        for label, number in zip(_labels(m), (value, low, high), strict=True):
            if not math.isnan(number):
                out[label] = float(number)
    return out


@dataclass(frozen=True)
class ChallengePart:
    """A phase's gold part: its data folder and manifest."""

    phase: str
    data: Path
    manifest: Manifest

    @property
    def split_codename(self) -> str:
        """The EvalAI dataset split of the phase."""
        return _SPLIT_CODENAMES[self.phase]


def _part(phase: str, data: str | os.PathLike[str]) -> ChallengePart:
    folder = Path(data)
    if not (folder / MANIFEST_NAME).is_file():
        msg = (f"--{phase.split('-')[0]} {folder}: not a part folder with {MANIFEST_NAME}; "
               "give the full (gold) part, e.g. data/smoke/test")
        raise InvalidArgument(msg)
    manifest = read_manifest(folder)
    if manifest.inputs_only:
        msg = (f"--{phase.split('-')[0]} {folder} is an inputs-only pack: the scoring server "
               "needs the full part with its gold")
        raise InvalidArgument(msg)
    if phase == PRIVATE_PHASE and manifest.private is None:
        msg = (f"--private {folder} ({manifest.split}) is not a private part: its entropy is "
               "public, so anyone can regenerate its gold. Generate the private test from a "
               "spec whose part has \"entropy\": \"secret\" (nsrmp-bench generate --spec ... "
               "--secret-file ...; docs/challenge.md)")
        raise InvalidArgument(msg)
    return ChallengePart(phase, folder, manifest)


def _zip_dir(folder: Path, out: Path, names: list[str]) -> None:
    """``out``: the files ``names`` of ``folder``, stored (HDF5 is compressed already), with
    a fixed date so the same files give the same bytes."""
    out.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as z:
        for name in sorted(names):
            info = zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0))
            info.external_attr = 0o644 << 16
            z.writestr(info, (folder / name).read_bytes())


_INIT = '''"""EvalAI's entry point (written by `nsrmp-bench challenge --evalai`)."""

from .main import evaluate

__all__ = ["evaluate"]
'''

_MAIN = '''"""Score a submission with the public nsrmp-bench scorer.

EvalAI calls ``evaluate(test_annotation_file, user_submission_file, phase_codename,
**kwargs)``; this runs ``nsrmp_bench.evalai.evaluate_phase`` (the same scorer as
``nsrmp-bench score``). The worker must have nsrmp-bench {version} installed beforehand
(``requirements.txt`` beside this file pins it): nothing is installed at evaluation time.
"""

import json
from pathlib import Path

VERSION = "{version}"
PHASES = json.loads((Path(__file__).parent / "{phases}").read_text("utf-8"))


def _scorer():
    try:
        import nsrmp_bench
    except ImportError as exc:
        raise RuntimeError(
            f"nsrmp-bench {{VERSION}} is not installed on this worker; install it before "
            f"the challenge opens: pip install -r requirements.txt") from exc
    if nsrmp_bench.__version__ != VERSION:
        raise RuntimeError(
            f"this worker has nsrmp-bench {{nsrmp_bench.__version__}}, but the challenge is "
            f"scored with {{VERSION}}; install the pinned one: pip install -r requirements.txt")
    from nsrmp_bench.evalai import evaluate_phase

    return evaluate_phase


def evaluate(test_annotation_file, user_submission_file, phase_codename, **kwargs):
    evaluate_phase = _scorer()
    print(f"nsrmp-bench: scoring {{user_submission_file}} for phase {{phase_codename}}")
    return evaluate_phase(test_annotation_file, user_submission_file, phase_codename, PHASES)
'''


def _same_manifest(folder: Path, annotation: Path) -> bool:
    """Whether the unpacked ``folder``'s manifest is byte for byte the annotation's (the
    shards are then checked against it when the gold is loaded)."""
    try:
        with zipfile.ZipFile(annotation) as z:
            return z.read(MANIFEST_NAME) == (folder / MANIFEST_NAME).read_bytes()
    except (OSError, KeyError, zipfile.BadZipFile):
        return False


def _unpacked(annotation: Path) -> Path:
    """The phase's gold part unpacked (once per worker, in the temporary folder, named by
    the annotation file's sha256). A cached folder is reused only when its manifest is the
    annotation's; its shards are checked against that manifest when scored, so a tampered
    cache is refused, not scored."""
    digest = hashlib.sha256(annotation.read_bytes()).hexdigest()[:24]
    folder = Path(tempfile.gettempdir()) / "nsrmp-bench-annotations" / digest
    if (folder / MANIFEST_NAME).is_file():
        if _same_manifest(folder, annotation):
            return folder
        msg = (f"the cached gold {folder} of annotation file {annotation} holds another "
               f"{MANIFEST_NAME} than the annotation file; it was changed on this worker: "
               "remove the folder (it is unpacked again) and check who can write there")
        raise DataIntegrityError(msg)
    folder.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f"{digest}-", dir=folder.parent))
    try:
        with zipfile.ZipFile(annotation) as z:
            for name in z.namelist():
                plain_name(name, what=f"annotation file {annotation}: the member",
                           fix="it holds one part's files only (manifest.json and shards), "
                               "as the bundle wrote it: upload that file")
            z.extractall(staging)
    except zipfile.BadZipFile as exc:
        shutil.rmtree(staging, ignore_errors=True)
        msg = (f"annotation file {annotation} is not a zip ({exc}); upload the "
               "annotations/<phase>.zip that `nsrmp-bench challenge --evalai` wrote")
        raise InvalidArgument(msg) from exc
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    try:
        os.replace(staging, folder)
    except OSError:  # another worker unpacked it first
        shutil.rmtree(staging, ignore_errors=True)
    return folder


def evaluate_phase(test_annotation_file: str | os.PathLike[str],
                   user_submission_file: str | os.PathLike[str], phase_codename: str,
                   phases: Mapping[str, Any], *,
                   time_limit_s: float = EVALUATION_TIME_LIMIT_S) -> dict[str, Any]:
    """EvalAI's result object for one submission: ``{"result": [{split: figures}],
    "submission_result": figures, "submission_metadata": {"scorer": ...}}`` with
    :func:`figures` of the public scorer's result and the scorer that made them.

    ``phases`` is the bundle's ``phases.json``. A submission the checks refuse (another
    split, another manifest, malformed lines, a file past its part's bounds) raises
    :class:`SubmissionError` naming the problems, which EvalAI shows the participant. The
    evaluation runs in a child process (``python -m nsrmp_bench.evalai``, :func:`_child`)
    stopped after ``time_limit_s`` seconds, which is then a :class:`ResourceLimit`; an
    error of the package there is raised here with its class and message.
    """
    command = [sys.executable, "-m", "nsrmp_bench.evalai", str(test_annotation_file),
               str(user_submission_file), phase_codename, json.dumps(dict(phases))]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=time_limit_s,
                              check=False)
    except subprocess.TimeoutExpired as exc:
        msg = (f"scoring {user_submission_file} for phase {phase_codename!r} took longer than "
               f"{time_limit_s:g} s and was stopped; a valid file of the part scores in far "
               "less: check that the file is the one made for this phase")
        raise ResourceLimit(msg) from exc
    lines = done.stdout.strip().splitlines()
    try:
        outcome: dict[str, Any] = json.loads(lines[-1]) if lines else {}
    except json.JSONDecodeError:
        outcome = {}
    if "result" in outcome:
        result: dict[str, Any] = outcome["result"]
        return result
    if "error" in outcome:
        cls = getattr(error_classes, str(outcome["error"]), SubmissionError)
        raise (cls if isinstance(cls, type) and issubclass(cls, NSRMPError)
               else SubmissionError)(str(outcome["message"]))
    msg = (f"scoring {user_submission_file} for phase {phase_codename!r} failed in its "
           f"process (exit {done.returncode}): {done.stderr.strip()[-2000:]}")
    raise ResourceLimit(msg)


def evaluate_in_process(test_annotation_file: str | os.PathLike[str],
                        user_submission_file: str | os.PathLike[str], phase_codename: str,
                        phases: Mapping[str, Any]) -> dict[str, Any]:
    """:func:`evaluate_phase`'s work, in this process and without a time limit."""
    if phase_codename not in phases:
        msg = (f"phase codename {phase_codename!r} is not one of this challenge's "
               f"{sorted(phases)}; the challenge_config.yaml and phases.json disagree")
        raise InvalidArgument(msg)
    phase = phases[phase_codename]
    gold = _unpacked(Path(test_annotation_file))
    root = read_manifest(gold).root_hash
    if root != phase["manifest_root_hash"]:
        msg = (f"the annotation file of phase {phase_codename!r} holds the part with root "
               f"hash {root[:16]}..., but the phase was made for {phase['part']} with "
               f"{str(phase['manifest_root_hash'])[:16]}...; upload the annotation file "
               "the bundle wrote for this phase")
        raise InvalidArgument(msg)
    submission = Path(user_submission_file)
    try:
        check_submission(submission, split=str(phase["part"]), data=gold)
    except InvalidArgument as exc:
        raise SubmissionError(str(exc)) from exc
    result = score(submission, gold)  # the defaults of `nsrmp-bench score`
    numbers = figures(result)
    return {"result": [{str(phase["split_codename"]): numbers}],
            "submission_result": numbers, "submission_metadata": {"scorer": result.scorer}}


def requirements(wheel: str | os.PathLike[str] | None = None) -> str:
    """The evaluation script's ``requirements.txt``: this version of nsrmp-bench, pinned by
    the sha256 of ``wheel`` when given (pip then installs nothing else under that name).
    The worker installs it before the challenge opens; nothing is installed when scoring."""
    line = f"nsrmp-bench=={__version__}"
    if wheel is not None:
        path = Path(wheel)
        if not path.is_file() or path.suffix != ".whl":
            msg = (f"--wheel {str(path)!r} is not a wheel file; pass the release's "
                   f"nsrmp_bench-{__version__}-*.whl (python -m build --wheel)")
            raise InvalidArgument(msg)
        line += f" --hash=sha256:{hashlib.sha256(path.read_bytes()).hexdigest()}"
    return ("# install on the EvalAI worker before the challenge opens: "
            "pip install --require-hashes -r requirements.txt\n" if wheel is not None else
            "# install on the EvalAI worker before the challenge opens (pass --wheel to "
            "`nsrmp-bench challenge` to pin it by hash): pip install -r requirements.txt\n"
            ) + line + "\n"


def _yaml(data: object) -> str:
    text: str = require("yaml").safe_dump(data, sort_keys=False, allow_unicode=True, width=88)
    return text


def _templates(title: str, parts: list[ChallengePart]) -> dict[str, str]:
    rows = "".join(
        f"<li><b>{p.phase}</b>: {p.manifest.split}, {p.manifest.count} instances, manifest "
        f"root hash <code>{p.manifest.root_hash}</code>"
        + (f", commitment <code>{p.manifest.private['commitment']}</code>"
           if p.manifest.private else "") + "</li>"
        for p in parts)
    return {
        "description.html": (
            f"<p>{title}: language-guided tabletop manipulation. Given an instruction and "
            "the initial scene (RGB-D image, object boxes, camera), predict where every "
            "object ends up (its final 2D box) after the instruction is carried out.</p>"
            f"<ul>{rows}</ul>"),
        "evaluation_details.html": (
            "<p>Submissions are scored by the public nsrmp-bench scorer (<code>nsrmp-bench "
            "score</code>) with its defaults: mean IoU over moved objects (IoU-M, the "
            "headline), mean IoU over all objects, success, program accuracy, "
            "identification and placement, each with its 95% bootstrap interval. Missing "
            "instances score zero. A file whose header protocol names another manifest is "
            "refused.</p>"),
        "submission_guidelines.html": (
            "<p>Download the inputs-only parts, run your model, and upload one predictions "
            "file (JSON Lines or Parquet) per phase, with the header's <code>protocol</code> "
            "(supervision, boxes, training parts, seeds, scorer, manifest root hash). Check "
            "it first: <code>nsrmp-bench check-submission P.jsonl --split SPLIT --data "
            "PART</code>.</p>"),
        "terms_and_conditions.html": (
            "<p>Do not train or select on the test parts. The private test's secret is "
            "revealed after the challenge; its commitment, published now, lets anyone check "
            "that the data did not change.</p>"),
        "public_test_phase.html": (
            "<p>The public test: its gold can be regenerated from the public spec, so its "
            "board is for checking a pipeline, not for ranking.</p>"),
        "private_test_phase.html": (
            "<p>The private test: its entropy is a secret held by the organisers, committed "
            "to in its manifest and revealed after the challenge. Its board ranks the "
            "entries.</p>"),
    }


def write_bundle(out: str | os.PathLike[str], public: str | os.PathLike[str],
                 private: str | os.PathLike[str], *, title: str = "nsrmp-bench challenge",
                 start_date: str = "2027-01-01 00:00:00",
                 end_date: str = "2027-12-31 23:59:59",
                 wheel: str | os.PathLike[str] | None = None) -> list[Path]:
    """Write the EvalAI bundle into ``out`` (see the module doc) from the full ``public``
    and ``private`` test parts; returns the files written. ``wheel`` (the release's wheel
    file) pins the package by its sha256 in ``requirements.txt``."""
    parts = [_part(PUBLIC_PHASE, public), _part(PRIVATE_PHASE, private)]
    require("yaml")  # before any file is written
    root = Path(out)
    script = root / "evaluation_script"
    script.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    phases = {p.phase: {"split_codename": p.split_codename, "part": p.manifest.split,
                        "manifest_root_hash": p.manifest.root_hash} for p in parts}
    files = {
        script / "__init__.py": _INIT,
        script / "main.py": _MAIN.format(version=__version__, phases=PHASES_FILE),
        script / PHASES_FILE: json.dumps(phases, indent=1, sort_keys=True) + "\n",
        script / REQUIREMENTS_FILE: requirements(wheel),
    }
    for name, text in _templates(title, parts).items():
        files[root / "templates" / name] = text + "\n"
    for part in parts:
        names = [s.file for s in part.manifest.shards] + [MANIFEST_NAME]
        _zip_dir(part.data, root / "annotations" / f"{part.phase}.zip", names)
        written.append(root / "annotations" / f"{part.phase}.zip")
        pack(part.data, root / "participant_data", inputs_only=True)
    files[root / "challenge_config.yaml"] = _yaml(_config(title, parts, start_date, end_date))
    for path, text in files.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, "utf-8")
        written.append(path)
    _zip_dir(script, root / "evaluation_script.zip",
             ["__init__.py", "main.py", PHASES_FILE, REQUIREMENTS_FILE])
    written.append(root / "evaluation_script.zip")
    return sorted(written)


def _config(title: str, parts: list[ChallengePart], start: str, end: str) -> dict[str, Any]:
    phases = []
    for n, part in enumerate(parts, 1):
        private = part.phase == PRIVATE_PHASE
        phases.append({
            "id": n,
            "name": "Private test" if private else "Public test",
            "description": f"templates/{part.split_codename}_phase.html",
            "leaderboard_public": True,
            "is_public": True,
            "is_submission_public": True,
            "start_date": start,
            "end_date": end,
            "test_annotation_file": f"annotations/{part.phase}.zip",
            "codename": part.phase,
            "max_submissions_per_day": 3 if private else 10,
            "max_submissions_per_month": 30 if private else 100,
            "max_submissions": 60 if private else 300,
            "is_restricted_to_select_one_submission": private,
            "is_partial_submission_evaluation_enabled": False,
            "allowed_submission_file_types": ".jsonl, .gz, .parquet",
        })
    return {
        "title": title,
        "short_description": ("Language-guided robot manipulation: predict every object's "
                              "final box; scored by the public nsrmp-bench scorer"),
        "description": "templates/description.html",
        "evaluation_details": "templates/evaluation_details.html",
        "terms_and_conditions": "templates/terms_and_conditions.html",
        "submission_guidelines": "templates/submission_guidelines.html",
        "leaderboard_description": ("IoU-M (mean IoU of moved objects' final boxes) is the "
                                    "headline; every value with its 95% bootstrap interval"),
        "evaluation_script": "evaluation_script.zip",
        "remote_evaluation": False,
        "start_date": start,
        "end_date": end,
        "published": False,
        "tags": ["robotics", "manipulation", "language grounding", "nsrmp-bench"],
        "leaderboard": [{"id": 1, "schema": leaderboard_schema()}],
        "challenge_phases": phases,
        "dataset_splits": [
            {"id": n, "name": f"{'Private' if p.phase == PRIVATE_PHASE else 'Public'} test "
             f"({p.manifest.split})", "codename": p.split_codename}
            for n, p in enumerate(parts, 1)],
        "challenge_phase_splits": [
            {"challenge_phase_id": n, "leaderboard_id": 1, "dataset_split_id": n,
             # 3: everyone sees the public board; 1: only the hosts see the private one
             # until they make it public at the end (the secret's reveal)
             "visibility": 1 if p.phase == PRIVATE_PHASE else 3,
             "leaderboard_decimal_precision": 4,
             "is_leaderboard_order_descending": _HIGHER_IS_BETTER}
            for n, p in enumerate(parts, 1)],
    }


def _child(argv: list[str]) -> int:
    """The child process of :func:`evaluate_phase`: evaluates ``argv = [annotation,
    submission, phase, phases as JSON]`` and prints one JSON object, ``{"result": ...}`` or
    ``{"error": class name, "message": ...}`` for an error of the package."""
    annotation, submission, phase, phases = argv
    try:
        out = evaluate_in_process(annotation, submission, phase, json.loads(phases))
    except NSRMPError as exc:
        print(json.dumps({"error": type(exc).__name__, "message": str(exc)}))
        return 2
    print(json.dumps({"result": out}))
    return 0


if __name__ == "__main__":
    raise SystemExit(_child(sys.argv[1:]))
