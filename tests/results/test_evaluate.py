"""``nsrmp-bench evaluate``: baselines and predictions files on the official test parts,
generated on demand; every figure is the public scorer's."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import pytest
from site_build import BOARDS

from nsrmp_bench.cli.evaluate import runners
from nsrmp_bench.errors import InvalidArgument, UnknownId
from nsrmp_bench.results.evaluate import find_part, official_test_parts, resolve_source
from nsrmp_bench.results.summary import Results
from nsrmp_bench.scoring.scorer import score

SMOKE_NSRM = BOARDS / "predictions" / "smoke-v2-test--nsrm-v1.jsonl.gz"


def test_sources_are_ids_or_files_and_anything_else_is_named(tmp_path: Path) -> None:
    assert resolve_source("oracle").name == "oracle-v1"
    assert resolve_source("nsrm", runners().models).kind == "model"
    with pytest.raises(UnknownId):
        resolve_source("nsrm")  # the core alone knows no learned model
    assert resolve_source(str(SMOKE_NSRM)).kind == "file"
    with pytest.raises(UnknownId, match=r"neither a predictions file.*baselines: oracle-v1"):
        resolve_source("oracel")
    with pytest.raises(InvalidArgument, match=r"does not exist"):
        resolve_source(str(tmp_path / "p.jsonl"))
    assert "paper-v2/test" in official_test_parts() and "smoke-v2/test" in official_test_parts()


def test_parts_are_found_by_split_id_or_short_name(tmp_path: Path) -> None:
    (tmp_path / "paper" / "test").mkdir(parents=True)
    (tmp_path / "paper" / "test" / "manifest.json").write_text("{}")
    assert find_part(tmp_path, "paper-v2/test") == tmp_path / "paper" / "test"
    assert find_part(tmp_path, "steps-v2/test") is None


def test_nothing_found_says_how_to_get_data(tmp_path: Path) -> None:
    from nsrmp_bench.results.evaluate import evaluate

    with pytest.raises(InvalidArgument, match=r"no official test part under.*--generate"):
        evaluate(["noop"], tmp_path, tmp_path / "out")
    with pytest.raises(InvalidArgument, match=r"--splits papr-v1: not an official split"):
        evaluate(["noop"], tmp_path, tmp_path / "out", splits=["papr-v1"])
    with pytest.raises(InvalidArgument, match=r"is for smoke-v2/test, which is not under"):
        evaluate([str(SMOKE_NSRM)], tmp_path, tmp_path / "out")


@pytest.mark.sim
def test_evaluate_generates_scores_and_writes_the_results(tmp_path: Path) -> None:
    pytest.importorskip("pybullet")
    root, out = tmp_path / "data", tmp_path / "results"
    root.mkdir()
    proc = subprocess.run(
        [sys.executable, "-m", "nsrmp_bench.cli.main", "evaluate", "oracle", "noop",
         str(SMOKE_NSRM), "--data-root", str(root), "--out", str(out), "--splits",
         "smoke-v2", "--generate"], check=True, capture_output=True, text=True, timeout=600)
    assert "IoU-M [95% CI] per split part" in proc.stdout
    data = root / "smoke-v2" / "test"
    assert (data / "manifest.json").is_file()
    results = Results.read(out)
    assert [(r.model, r.split) for r in results.runs] == [
        ("oracle-v1", "smoke-v2/test"), ("noop-v1", "smoke-v2/test"),
        ("nsrm-v1", "smoke-v2/test")]
    for run in results.runs:
        direct = score(out / run.predictions, data)
        assert run.metric("iou_m").value == direct.value("iou_m")
        assert run.metric("iou_m").low == direct.interval("iou_m")[0]
        assert run.group("steps", "2", "iou").value == direct.breakdown("iou").loc[
            ("steps", "2"), "value"]
    assert results.run("oracle-v1", "smoke-v2/test").metric("iou_m").value > 0.99  # type: ignore[union-attr]
    with (out / "smoke-v2-test.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert {r["model"] for r in rows} == {"oracle-v1", "noop-v1", "nsrm-v1"}
    templates = [r for r in rows if r["category"] == "template"]
    assert templates, "the CSV keeps every category, templates included"
    overall = next(r for r in rows if r["model"] == "noop-v1" and r["category"] == "all"
                   and r["metric"] == "iou_m")
    assert float(overall["value"]) == results.run("noop-v1", "smoke-v2/test").metric(  # type: ignore[union-attr]
        "iou_m").value


@pytest.mark.sim
@pytest.mark.dask
def test_evaluate_on_dask_gives_the_local_figures(tmp_path: Path) -> None:
    """One task per (source, part) run: a 2-worker Dask cluster writes the same summary and
    CSV as this process."""
    pytest.importorskip("pybullet")
    pytest.importorskip("distributed")
    from nsrmp_bench.cli.main import main
    from nsrmp_bench.generators.generate import generate_part
    from nsrmp_bench.split_specs import load_split

    root = tmp_path / "data"
    generate_part(load_split("smoke-v2"), "test", root / "smoke-v2" / "test", workers=1)
    sources = ["oracle", "noop", "random", str(SMOKE_NSRM)]
    common = ["--data-root", str(root), "--splits", "smoke-v2", "--quiet"]
    assert main(["evaluate", *sources, *common, "--out", str(tmp_path / "local"),
                 "--workers", "1"]) == 0
    assert main(["evaluate", *sources, *common, "--out", str(tmp_path / "dask"),
                 "--engine", "dask", "--workers", "2"]) == 0
    local, dask = Results.read(tmp_path / "local"), Results.read(tmp_path / "dask")
    assert [(r.model, r.split) for r in dask.runs] == [(r.model, r.split) for r in local.runs]
    assert len(local.runs) == 4
    for name in ("summary.json", "smoke-v2-test.csv"):
        assert (tmp_path / "dask" / name).read_bytes() == (tmp_path / "local" / name).read_bytes()
    for name in ("smoke-v2-test--oracle-v1.jsonl", "smoke-v2-test--random-v1.jsonl"):
        assert ((tmp_path / "dask" / "predictions" / name).read_bytes()
                == (tmp_path / "local" / "predictions" / name).read_bytes())


@pytest.mark.sim
def test_evaluate_with_the_robustness_suite_keeps_its_tables(smoke_v2_root: Path,
                                                             tmp_path: Path) -> None:
    """``--robustness``: the suite for the id sources on each part, in summary.json."""
    from nsrmp_bench.cli.main import main
    from nsrmp_bench.results.summary import Results

    root = tmp_path / "data"
    root.mkdir()
    (root / "smoke-v2").symlink_to(smoke_v2_root, target_is_directory=True)
    out = tmp_path / "results"
    assert main(["evaluate", "noop", "--data-root", str(root), "--out", str(out),
                 "--splits", "smoke-v2", "--workers", "1", "--robustness", "--quiet"]) == 0
    results = Results.read(out)
    (suite,) = results.robustness
    assert suite.split == "smoke-v2/test" and len(suite.kinds) == 8
    assert all(r.source == "noop-v1" and r.diff == 0.0 for r in suite.rows)
    assert (out / "robustness" / "smoke-v2-test" / "robustness.json").is_file()
    assert Results.read(out).to_json() == results.to_json()
