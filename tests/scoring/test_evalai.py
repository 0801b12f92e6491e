"""`nsrmp-bench challenge --evalai` on a generated smoke-v2 (public test) and a tiny private
part: the bundle's `evaluate`, imported and called the way EvalAI's worker does, returns
exactly the public scorer's figures for each phase; the config's phases, splits and
leaderboard schema agree with it; the participants' copies hold no gold; a public part as
the private test, or a submission made on another part, is refused with the fix."""

from __future__ import annotations

import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from nsrmp_bench.baselines.registry import run_baseline
from nsrmp_bench.errors import InvalidArgument, NSRMPError
from nsrmp_bench.evalai import write_bundle
from nsrmp_bench.leaderboard import COLUMNS
from nsrmp_bench.scoring.gold import load_episodes
from nsrmp_bench.scoring.metrics import METRICS_V2
from nsrmp_bench.scoring.scorer import score
from nsrmp_bench.split_specs import load_split_file
from nsrmp_bench.storage.manifest import read_manifest

pytestmark = pytest.mark.sim
yaml = pytest.importorskip("yaml")

LABELS = {m.name: m.label for m in METRICS_V2}
SECRET = "5e" * 32
SPEC = {"id": "hiddenchallenge-v1", "description": "a private test for the tests",
        "image": [160, 120],
        "parts": {"test": {"count": 4, "entropy": "secret",
                           "strata": [{"objects": [3, 4], "steps": [1, 2]}]}}}


@pytest.fixture(scope="module")
def made(smoke_v2_test: Path, tmp_path_factory: pytest.TempPathFactory
         ) -> tuple[Path, Path, Path]:
    from nsrmp_bench.generators.generate import generate_part

    tmp = tmp_path_factory.mktemp("evalai")
    (tmp / "spec.json").write_text(json.dumps(SPEC))
    private = tmp / "private" / "test"
    generate_part(load_split_file(tmp / "spec.json"), "test", private, workers=1,
                  secret=SECRET)
    out = tmp / "bundle"
    done = subprocess.run(
        [sys.executable, "-m", "nsrmp_bench.cli.main", "challenge", "--evalai", str(out),
         "--public", str(smoke_v2_test), "--private", str(private), "--title", "test"],
        capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    return out, smoke_v2_test, private


def _evaluation_script(bundle: Path) -> ModuleType:
    """The bundle's evaluation_script package, imported as EvalAI's worker imports it."""
    init = bundle / "evaluation_script" / "__init__.py"
    spec = importlib.util.spec_from_file_location(
        "evaluation_script", init, submodule_search_locations=[str(init.parent)])
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["evaluation_script"] = module
    spec.loader.exec_module(module)
    return module


def _noop(data: Path, out: Path) -> Path:
    episodes, split = load_episodes(data)
    return run_baseline("noop-v1", episodes, out, split=str(split),
                        manifest_root_hash=read_manifest(data).root_hash)


def _oracle(data: Path, out: Path) -> Path:
    episodes, split = load_episodes(data)
    return run_baseline("oracle-v1", episodes, out, split=str(split),
                        manifest_root_hash=read_manifest(data).root_hash)


@pytest.mark.parametrize("phase", ["public-test", "private-test"])
def test_evaluate_returns_exactly_the_scorers_figures(
        made: tuple[Path, Path, Path], tmp_path: Path, phase: str) -> None:
    bundle, public, private = made
    data = public if phase == "public-test" else private
    script = _evaluation_script(bundle)
    for make in (_noop, _oracle):
        predictions = make(data, tmp_path / f"{make.__name__}.jsonl")
        out: dict[str, Any] = script.evaluate(
            str(bundle / "annotations" / f"{phase}.zip"), str(predictions), phase,
            submission_metadata={"method_name": "x"})
        split = "public_test" if phase == "public-test" else "private_test"
        got = out["result"][0][split]
        assert out["submission_result"] == got
        expected = score(predictions, data)
        compared = 0
        for metric in COLUMNS:
            if metric not in expected.summary.index:
                continue
            label = LABELS[metric]
            low, high = expected.interval(metric)
            for key, number in ((label, expected.value(metric)), (f"{label} 95% low", low),
                                (f"{label} 95% high", high)):
                if math.isnan(number):
                    assert key not in got
                else:
                    assert got[key] == number, (key, got[key], number)
                    compared += 1
        assert compared >= 6 and {"IoU-M", "IoU"} <= set(got)
        labels = set(yaml.safe_load((bundle / "challenge_config.yaml").read_text())
                     ["leaderboard"][0]["schema"]["labels"])
        assert set(got) <= labels and "IoU-M" in got
        json.dumps(out, allow_nan=False)  # EvalAI stores it as JSON


def test_the_config_names_two_phases_their_splits_and_annotation_files(
        made: tuple[Path, Path, Path]) -> None:
    bundle, _, private = made
    config = yaml.safe_load((bundle / "challenge_config.yaml").read_text())
    phases = {p["codename"]: p for p in config["challenge_phases"]}
    assert set(phases) == {"public-test", "private-test"}
    for phase in phases.values():
        assert (bundle / phase["test_annotation_file"]).is_file()
        assert (bundle / phase["description"]).is_file()
    splits = {s["id"]: s["codename"] for s in config["dataset_splits"]}
    assert sorted(splits.values()) == ["private_test", "public_test"]
    visibility = {splits[s["dataset_split_id"]]: s["visibility"]
                  for s in config["challenge_phase_splits"]}
    assert visibility == {"public_test": 3, "private_test": 1}
    schema = config["leaderboard"][0]["schema"]
    assert schema["default_order_by"] == "IoU-M" and schema["labels"][:3] == [
        "IoU-M", "IoU-M 95% low", "IoU-M 95% high"]
    assert (bundle / config["evaluation_script"]).is_file()
    for name in ("description", "evaluation_details", "terms_and_conditions",
                 "submission_guidelines"):
        assert (bundle / config[name]).is_file()
    commitment = read_manifest(private).private
    assert commitment is not None
    assert commitment["commitment"] in (bundle / "templates" / "description.html").read_text()
    cut = read_manifest(bundle / "participant_data" / "hiddenchallenge-v1" / "test")
    assert cut.inputs_only and cut.root_hash == read_manifest(private).root_hash


def test_a_submission_made_on_another_part_or_phase_is_refused(
        made: tuple[Path, Path, Path], tmp_path: Path) -> None:
    bundle, public, _ = made
    script = _evaluation_script(bundle)
    predictions = _noop(public, tmp_path / "noop.jsonl")
    with pytest.raises(NSRMPError, match="hiddenchallenge-v1/test"):
        script.evaluate(str(bundle / "annotations" / "private-test.zip"), str(predictions),
                        "private-test")
    lines = predictions.read_text().splitlines()
    header = json.loads(lines[0])
    header["header"]["protocol"]["manifest_root_hash"] = "ef" * 32
    other = tmp_path / "other.jsonl"
    other.write_text("\n".join([json.dumps(header), *lines[1:]]) + "\n")
    with pytest.raises(NSRMPError, match="made on another manifest"):
        script.evaluate(str(bundle / "annotations" / "public-test.zip"), str(other),
                        "public-test")
    with pytest.raises(InvalidArgument, match="not one of this challenge's"):
        script.evaluate(str(bundle / "annotations" / "public-test.zip"), str(predictions),
                        "dev")


def test_a_public_part_as_the_private_test_is_refused(
        made: tuple[Path, Path, Path], tmp_path: Path) -> None:
    _, public, _ = made
    with pytest.raises(InvalidArgument, match="is not a private part"):
        write_bundle(tmp_path / "b", public, public)


def test_the_bundle_installs_nothing_at_evaluation_time(made: tuple[Path, Path, Path]) -> None:
    bundle, _, _ = made
    main = (bundle / "evaluation_script" / "main.py").read_text()
    assert "pip" not in main.replace("pip install -r requirements.txt", "")
    assert "subprocess" not in main
    requirements = (bundle / "evaluation_script" / "requirements.txt").read_text()
    from nsrmp_bench import __version__

    assert f"nsrmp-bench=={__version__}" in requirements
    import zipfile

    with zipfile.ZipFile(bundle / "evaluation_script.zip") as z:
        assert "requirements.txt" in z.namelist()


def test_a_tampered_cached_gold_is_refused(made: tuple[Path, Path, Path], tmp_path: Path) -> None:
    from nsrmp_bench.errors import DataIntegrityError
    from nsrmp_bench.evalai import _unpacked, evaluate_in_process

    bundle, public, _ = made
    annotation = bundle / "annotations" / "public-test.zip"
    phases = json.loads((bundle / "evaluation_script" / "phases.json").read_text())
    predictions = _noop(public, tmp_path / "noop.jsonl")
    cached = _unpacked(annotation)
    shard = sorted(cached.glob("shard-*.h5"))[0]
    original = shard.read_bytes()
    try:
        data = bytearray(original)
        data[len(data) // 2] ^= 0xFF
        shard.write_bytes(bytes(data))
        with pytest.raises(DataIntegrityError, match="but the manifest says"):
            evaluate_in_process(annotation, predictions, "public-test", phases)
    finally:
        shard.write_bytes(original)


def test_an_evaluation_past_its_time_limit_is_stopped(
        made: tuple[Path, Path, Path], tmp_path: Path) -> None:
    from nsrmp_bench.errors import ResourceLimit
    from nsrmp_bench.evalai import evaluate_phase

    bundle, public, _ = made
    phases = json.loads((bundle / "evaluation_script" / "phases.json").read_text())
    predictions = _noop(public, tmp_path / "noop.jsonl")
    with pytest.raises(ResourceLimit, match=r"took longer than 0.01 s and was stopped"):
        evaluate_phase(bundle / "annotations" / "public-test.zip", predictions, "public-test",
                       phases, time_limit_s=0.01)


def test_a_gzip_bomb_is_refused_by_the_evaluator_at_its_parts_bound(
        made: tuple[Path, Path, Path], tmp_path: Path) -> None:
    import gzip
    import zlib

    from nsrmp_bench.errors import SubmissionError
    from nsrmp_bench.evalai import evaluate_phase

    bundle, public, _ = made
    phases = json.loads((bundle / "evaluation_script" / "phases.json").read_text())
    header = json.loads(_noop(public, tmp_path / "noop.jsonl").read_text().splitlines()[0])
    member = zlib.compressobj(9, zlib.DEFLATED, 31)
    one = member.compress(b"\n" * (16 << 20)) + member.flush()
    bomb = tmp_path / "bomb.jsonl.gz"  # 2 MB, 2 GiB of newlines after the header
    bomb.write_bytes(gzip.compress((json.dumps(header) + "\n").encode(), mtime=0) + one * 128)
    with pytest.raises(SubmissionError, match="reading stopped there"):
        evaluate_phase(bundle / "annotations" / "public-test.zip", bomb, "public-test", phases)
