"""Perturbed copies of a real part: same ids and gold, same bytes for the same seed, the
oracle at 1.000 on each, and the suite's table over them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import nsrmp_bench
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.results.robustness_table import read_suite
from nsrmp_bench.robustness.kinds import KINDS
from nsrmp_bench.robustness.part import RECORDS_NAME, perturb_part, read_records
from nsrmp_bench.robustness.suite import run_suite
from nsrmp_bench.storage.manifest import read_manifest
from nsrmp_bench.verify import verify

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def suite_dir(smoke_v2_test: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The suite over smoke-v2/test with the oracle and noop (every kind)."""
    out = tmp_path_factory.mktemp("suite")
    run_suite(["oracle", "noop"], smoke_v2_test, out)
    return out


def test_every_kind_keeps_ids_and_gold_and_records_what_changed(
        smoke_v2_test: Path, suite_dir: Path) -> None:
    source = nsrmp_bench.open(smoke_v2_test)
    for kind in KINDS:
        part = suite_dir / "parts" / kind
        manifest = read_manifest(part)
        assert manifest.perturbation is not None
        assert manifest.perturbation["kind"] == kind and manifest.perturbation["seed"] == 0
        assert not manifest.official
        records = read_records(part)
        copy = nsrmp_bench.open(part)
        assert copy.ids == source.ids == [r["id"] for r in records]
        for i in range(len(copy)):
            a, b = source.episode(i), copy.episode(i)
            assert a.symbolic.grounded == b.symbolic.grounded
            assert a.symbolic.states == b.symbolic.states
            assert b.symbolic.instruction.text == records[i]["text"]
            assert records[i]["original"] == a.symbolic.instruction.text
            assert records[i]["changed"] == (records[i]["text"] != records[i]["original"])
        changed = sum(r["changed"] for r in records)
        assert changed == manifest.perturbation["changed"]
        assert changed >= len(records) - (2 if kind == "reorder" else 0)
        assert verify(part).ok


def test_same_seed_same_bytes(smoke_v2_test: Path, suite_dir: Path, tmp_path: Path) -> None:
    perturb_part(smoke_v2_test, tmp_path / "again", kind="typo", seed=0)
    for f in sorted((suite_dir / "parts" / "typo").iterdir()):
        assert (tmp_path / "again" / f.name).read_bytes() == f.read_bytes(), f.name
    perturb_part(smoke_v2_test, tmp_path / "other", kind="typo", seed=1)
    assert read_records(tmp_path / "other") != read_records(tmp_path / "again")


def test_the_oracle_reads_no_instruction_and_scores_one_everywhere(suite_dir: Path) -> None:
    suite = read_suite(suite_dir / "robustness.json")
    assert suite.kinds == list(KINDS)
    for kind in KINDS:
        oracle, noop = suite.row("oracle-v1", kind), suite.row("noop-v1", kind)
        assert oracle is not None and noop is not None
        assert oracle.iou_m == pytest.approx(oracle.clean_iou_m) and oracle.iou_m > 0.999
        assert oracle.diff == pytest.approx(0.0)
        assert noop.iou_m < 0.05 and noop.control == (kind in ("blind", "shuffled"))
    assert "| oracle-v1 | 1.000 |" in (suite_dir / "robustness.md").read_text()


def test_bad_requests_are_refused_before_anything_is_written(
        smoke_v2_test: Path, suite_dir: Path, tmp_path: Path) -> None:
    with pytest.raises(InvalidArgument, match="already a perturbed part"):
        perturb_part(suite_dir / "parts" / "typo", tmp_path / "x", kind="case", seed=0)
    with pytest.raises(InvalidArgument, match="already holds a part"):
        perturb_part(smoke_v2_test, suite_dir / "parts" / "typo", kind="typo", seed=0)
    with pytest.raises(InvalidArgument, match="--kind 'shout'"):
        perturb_part(smoke_v2_test, tmp_path / "y", kind="shout", seed=0)
    with pytest.raises(InvalidArgument, match="--seed -1"):
        perturb_part(smoke_v2_test, tmp_path / "z", kind="typo", seed=-1)
    assert not (tmp_path / "y").exists() and not (tmp_path / "z").exists()
    with pytest.raises(InvalidArgument, match="perturbed part"):
        run_suite(["oracle"], suite_dir / "parts" / "case", tmp_path / "s")


def test_the_command_line(smoke_v2_test: Path, tmp_path: Path,
                          capsys: pytest.CaptureFixture[str]) -> None:
    from nsrmp_bench.cli.main import main

    out = tmp_path / "polite"
    assert main(["perturb", str(smoke_v2_test), "--kind", "polite", "--seed", "7", "--out",
                 str(out), "--quiet"]) == 0
    rows = [json.loads(line) for line in (out / RECORDS_NAME).read_text().splitlines()]
    assert len(rows) == 16 and all(r["changed"] for r in rows)
    assert main(["robustness", "oracle", "--data", str(smoke_v2_test), "--out",
                 str(tmp_path / "r"), "--kinds", "blind", "typo", "--board",
                 str(tmp_path / "board")]) == 0
    assert "blind" in capsys.readouterr().out
    board = read_suite(tmp_path / "board" / "smoke-v2-test.json")
    assert board.kinds == ["typo", "blind"]
    assert (tmp_path / "board" / "smoke-v2-test.md").read_text().startswith("# Robustness")
