"""``nsrmp-bench replay``: the robot carries out predictions; the normal scorer scores them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from robot_cases import generated

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.cli.main import main
from nsrmp_bench.scoring.scorer import score

pytestmark = pytest.mark.sim

SPLIT = "robot-replay-test-v1"


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Eight generated instances (1-3 steps, 4-11 objects) as symbolic JSON Lines."""
    path = tmp_path_factory.mktemp("replay") / "data.jsonl"
    lines = []
    for i in range(8):
        ep = generated(4 + i, 1 + i % 3, 200 + i, "any" if i % 2 else "none")
        lines.append(canonical_json(ep.to_dict()))
    path.write_text("\n".join(lines) + "\n", "utf-8")
    return path


def _baseline(name: str, data: Path) -> Path:
    out = data.parent / f"{name}.jsonl"
    if not out.exists():
        assert main(["baseline", name, "--data", str(data), "--out", str(out),
                     "--split", SPLIT]) == 0
    return out


def _replay(pred: Path, data: Path, out_name: str, *extra: str) -> tuple[Path, dict]:
    out = data.parent / out_name
    report = data.parent / (out_name + ".report.json")
    status = main(["replay", str(pred), "--data", str(data), "--out", str(out), "--split",
                   SPLIT, "--report", str(report), "--quiet", *extra])
    assert status == 0
    return out, json.loads(report.read_text("utf-8"))


def _iou_m(pred: Path, data: Path) -> float:
    return score(pred, data, split=SPLIT, n_boot=0, breakdown=False).headline


def test_replaying_the_oracle_scores_close_to_the_oracle(data: Path) -> None:
    oracle = _baseline("oracle", data)
    replayed, report = _replay(oracle, data, "oracle.robot.jsonl")
    assert report["totals"]["moves"] == report["totals"]["moves_succeeded"] > 0
    assert report["totals"]["moves_refused"] == 0
    own = _iou_m(oracle, data)
    assert own == pytest.approx(1.0)
    assert _iou_m(replayed, data) > own - 0.02
    # the replayed file keeps the plan and says what made it
    lines = replayed.read_text("utf-8").splitlines()
    header = json.loads(lines[0])["header"]
    assert header["split"] == SPLIT and header["replay"]["executor"] == "robot-v1"
    assert "robot replay" in header["model"]
    first = json.loads(lines[1])
    assert first["program"] and len(first["boxes"]) == len(first["positions"])


def _boxes_only(data: Path) -> Path:
    """The oracle's predictions without program, positions and step boxes."""
    out = data.parent / "oracle_boxes.jsonl"
    if not out.exists():
        lines = _baseline("oracle", data).read_text("utf-8").splitlines()
        stripped = [lines[0]]
        for line in lines[1:]:
            rec = json.loads(line)
            for key in ("program", "positions", "step_boxes"):
                rec.pop(key, None)
            stripped.append(json.dumps(rec))
        out.write_text("\n".join(stripped) + "\n", "utf-8")
    return out


def test_replaying_only_the_oracle_boxes_back_projects_them(data: Path) -> None:
    oracle = _baseline("oracle", data)
    replayed, report = _replay(_boxes_only(data), data, "oracle_boxes.robot.jsonl")
    assert all(i["plan"]["source"] == "boxes" for i in report["instances"])
    assert report["totals"]["moves"] == report["totals"]["moves_succeeded"] > 0
    assert _iou_m(replayed, data) > _iou_m(oracle, data) - 0.02


def test_replaying_noop_moves_nothing(data: Path) -> None:
    noop = _baseline("noop", data)
    replayed, report = _replay(noop, data, "noop.robot.jsonl")
    assert report["totals"]["moves"] == 0
    assert _iou_m(replayed, data) == pytest.approx(_iou_m(noop, data), abs=1e-3)


def test_a_missing_source_leaves_the_scene_as_it_was_and_says_so(data: Path) -> None:
    replayed, report = _replay(_boxes_only(data), data, "no_program.robot.jsonl",
                               "--source", "program", "--limit", "2")
    assert report["totals"]["instances"] == 2
    assert report["totals"]["nothing_to_carry_out"] == 2
    assert "has no program" in report["instances"][0]["error"]
    lines = replayed.read_text("utf-8").splitlines()
    assert len(lines) == 3  # header and both instances, boxes where the objects stood


def test_two_workers_write_the_same_bytes_as_one(data: Path) -> None:
    oracle = _baseline("oracle", data)
    one, _ = _replay(oracle, data, "w1.jsonl", "--limit", "3")
    two, _ = _replay(oracle, data, "w2.jsonl", "--limit", "3", "--workers", "2")
    assert one.read_bytes() == two.read_bytes()


@pytest.mark.dask
def test_a_dask_cluster_writes_the_same_bytes_as_one_process(data: Path) -> None:
    pytest.importorskip("distributed")
    oracle = _baseline("oracle", data)
    one, _ = _replay(oracle, data, "d1.jsonl", "--limit", "6")
    on_dask, report = _replay(oracle, data, "dask.jsonl", "--limit", "6", "--engine", "dask",
                              "--workers", "2")  # two chunks, one per worker
    assert report["totals"]["instances"] == 6
    assert one.read_bytes() == on_dask.read_bytes()


def test_bad_arguments_exit_with_a_message(data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    oracle = _baseline("oracle", data)
    assert main(["replay", str(oracle), "--data", str(data), "--out", str(oracle),
                 "--split", SPLIT]) == 2
    assert "is the input file" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:  # argparse refuses it (cli/numbers.py)
        main(["replay", str(oracle), "--data", str(data), "--out",
              str(data.parent / "x.jsonl"), "--split", SPLIT, "--workers", "0"])
    assert exit_.value.code == 2
    assert "--workers: expected a whole number >= 1, got '0'" in capsys.readouterr().err
