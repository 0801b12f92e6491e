"""The detected-objects protocol: a line carries its own detected initial objects, with
boxes and program per detection; the scorer matches them to gold objects (Hungarian on
IoU) and scores unmatched gold objects as IoU 0."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from nsrmp_bench.baselines import run_baseline
from nsrmp_bench.errors import SubmissionError
from nsrmp_bench.geometry.boxes import box_iou
from nsrmp_bench.scoring import score
from nsrmp_bench.scoring.gold import load_gold
from nsrmp_bench.storage import open as open_data

pytest.importorskip("scipy")


def _lines(path: Path) -> tuple[dict, list[dict]]:
    rows = [json.loads(x) for x in path.read_text().splitlines()]
    return rows[0], rows[1:]


def _write(path: Path, header: dict, recs: list[dict]) -> Path:
    path.write_text("\n".join(json.dumps(r) for r in [header, *recs]) + "\n")
    return path


def _initial_boxes(data: Path) -> dict[str, np.ndarray]:
    col = open_data(data)
    return {col.read_inputs(i)["id"]: np.asarray(col.read_inputs(i)["boxes"], float)
            for i in range(len(col))}


def _as_detected(rec: dict, init: np.ndarray, order: np.ndarray) -> dict:
    """``rec`` (per gold object) rewritten per detection, detections = gold boxes in
    ``order`` (detection j is gold object order[j])."""
    inv = np.argsort(order)
    out = dict(rec)
    out["detections"] = init[order].tolist()
    out["boxes"] = [rec["boxes"][g] for g in order]
    if rec.get("step_boxes") is not None:
        out["step_boxes"] = [[s[g] for g in order] for s in rec["step_boxes"]]
    if rec.get("positions") is not None:
        out["positions"] = [rec["positions"][g] for g in order]
    if rec.get("program") is not None:
        out["program"] = [[a, int(inv[s]), int(inv[r])] for a, s, r in rec["program"]]
    return out


def _object_ious(gold, rec: dict) -> np.ndarray:
    g = gold.index[rec["id"]]
    o0, o1 = int(gold.obj_offsets[g]), int(gold.obj_offsets[g + 1])
    return box_iou(np.asarray(rec["boxes"], float), gold.final_boxes[o0:o1])


def _kept_object(gold, rec: dict) -> int:
    """An object the predictions file scores well on (so dropping it costs something)."""
    return int(np.argmax(_object_ious(gold, rec) > 0.5))


@pytest.fixture(scope="module")
def gold_file(tmp_path_factory: pytest.TempPathFactory, smoke_v2_test: Path) -> Path:
    out = tmp_path_factory.mktemp("detected") / "random.jsonl"
    col = open_data(smoke_v2_test)
    return run_baseline("random", col.iter_episodes(images=False), out, split=col.split)


def test_perfect_detector_reproduces_the_gold_box_score(gold_file: Path, tmp_path: Path, smoke_v2_test: Path):
    header, recs = _lines(gold_file)
    init = _initial_boxes(smoke_v2_test)
    rng = np.random.default_rng(0)
    det = [_as_detected(r, init[r["id"]], rng.permutation(len(r["boxes"]))) for r in recs]
    a = score(gold_file, smoke_v2_test, n_boot=0)
    b = score(_write(tmp_path / "det.jsonl", header, det), smoke_v2_test, n_boot=0)
    pd_cols = ["iou", "iou_m", "success", "program_exact", "subject_per_step",
               "identification", "placement"]
    np.testing.assert_allclose(b.per_instance[pd_cols].to_numpy(float),
                               a.per_instance[pd_cols].to_numpy(float), atol=1e-9)
    assert b.counts["detected_lines"] == len(recs)
    assert b.counts["detected_objects_unmatched"] == 0
    assert b.counts["detected_objects_matched"] == sum(len(r["boxes"]) for r in recs)


def test_dropping_one_detection_lowers_the_score_by_that_objects_share(
        gold_file: Path, tmp_path: Path, smoke_v2_test: Path):
    header, recs = _lines(gold_file)
    init = _initial_boxes(smoke_v2_test)
    full = [_as_detected(r, init[r["id"]], np.arange(len(r["boxes"]))) for r in recs]
    gold = load_gold(smoke_v2_test)
    i, j = 3, _kept_object(gold, recs[3])  # drop gold object j of instance i
    dropped = [dict(r) for r in full]
    rec = dict(recs[i])
    for key in ("program", "pick", "place"):  # the program may name the dropped object
        rec.pop(key, None)
        full[i].pop(key, None)
    keep = [g for g in range(len(rec["boxes"])) if g != j]
    dropped[i] = _as_detected(rec, init[rec["id"]], np.asarray(keep))
    a = score(_write(tmp_path / "full.jsonl", header, full), smoke_v2_test, n_boot=0)
    b = score(_write(tmp_path / "drop.jsonl", header, dropped), smoke_v2_test, n_boot=0)
    iid = recs[i]["id"]
    n_obj = len(recs[i]["boxes"])
    obj_iou = _object_ious(gold, recs[i])[j]
    drop = a.per_instance.loc[iid, "iou"] - b.per_instance.loc[iid, "iou"]
    assert drop == pytest.approx(obj_iou / n_obj, abs=1e-9)
    overall = a.summary.loc["iou", "value"] - b.summary.loc["iou", "value"]
    assert overall == pytest.approx(obj_iou / n_obj / len(recs), abs=1e-9)
    others = [x for x in a.per_instance.index if x != iid]
    np.testing.assert_allclose(b.per_instance.loc[others, "iou"], a.per_instance.loc[others, "iou"])
    assert b.counts["detected_objects_unmatched"] == 1


def test_bad_detected_lines_are_refused_with_their_line(gold_file: Path, tmp_path: Path, smoke_v2_test: Path):
    header, recs = _lines(gold_file)
    init = _initial_boxes(smoke_v2_test)
    det = [_as_detected(r, init[r["id"]], np.arange(len(r["boxes"]))) for r in recs]
    det[0]["boxes"] = det[0]["boxes"][:-1]  # one box fewer than detections
    det[2]["detections"][0] = [10, 10, 5, 5]  # x2 < x1
    det[4]["detections"][0] = [10, 10, 900, 20]  # outside the image
    det[6]["detections"] = 5  # not a list
    with pytest.raises(SubmissionError) as err:
        score(_write(tmp_path / "bad.jsonl", header, det), smoke_v2_test, n_boot=0)
    text = str(err.value)
    assert "line 2" in text and "'detections' has" in text
    assert "line 4" in text and "detections[0]" in text
    assert "line 6" in text and "outside" in text
    assert "line 8: 'detections' must be a list" in text
