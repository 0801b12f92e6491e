"""Detections files, detection metrics (COCO AP by pycocotools, cross-checked against an
independent 101-point AP here), and the classical detector on the smoke split."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from nsrmp_bench.errors import SubmissionError

pytest.importorskip("scipy")
pytest.importorskip("pycocotools")

from nsrmp_bench.detection.detections import (
    Detections,
    read_detections,
    write_detections,
)
from nsrmp_bench.detection.metrics import coco_ap, gold_scenes, score_detections
from nsrmp_bench.scoring.matching import hungarian_match, pairwise_iou


def _ap_101(gold: list[np.ndarray], det: list[np.ndarray], scores: list[np.ndarray],
            t: float) -> float:
    """COCO's single-class AP at IoU ``t``, written out independently of pycocotools:
    per image, detections by descending score take the unmatched gold box of highest IoU
    (>= t); precision is made monotone and read at 101 recall points."""
    records = []
    for g, d, s in zip(gold, det, scores, strict=True):
        iou = pairwise_iou(d, g)
        taken = np.zeros(len(g), bool)
        for k in np.argsort(-s, kind="stable"):
            cand = np.where(~taken & (iou[k] >= t), iou[k], -1.0)
            hit = len(g) > 0 and cand.max() >= 0
            if hit:
                taken[int(cand.argmax())] = True
            records.append((s[k], hit))
    n_gold = sum(len(g) for g in gold)
    records.sort(key=lambda r: -r[0])
    tp = np.cumsum([r[1] for r in records])
    fp = np.cumsum([not r[1] for r in records])
    recall = tp / n_gold
    precision = tp / np.maximum(tp + fp, 1)
    precision = np.maximum.accumulate(precision[::-1])[::-1]
    points = []
    for r in np.linspace(0, 1, 101):
        i = np.searchsorted(recall, r, side="left")
        points.append(precision[i] if i < len(precision) else 0.0)
    return float(np.mean(points))


def _scene(rng: np.random.Generator, n: int) -> np.ndarray:
    xy = rng.uniform(0, 280, (n, 2))
    wh = rng.uniform(15, 35, (n, 2))
    return np.concatenate([xy, xy + wh], 1)


def test_coco_ap_matches_an_independent_101_point_ap():
    rng = np.random.default_rng(7)
    gold, det, scores = [], [], []
    for _ in range(25):
        g = _scene(rng, int(rng.integers(1, 8)))
        d = g + rng.normal(0, 3.0, g.shape)  # jittered true positives
        d = d[rng.random(len(d)) > 0.2]  # some missed
        d = np.concatenate([d, _scene(rng, int(rng.integers(0, 3)))])  # false positives
        d[:, 2:] = np.maximum(d[:, 2:], d[:, :2] + 1)
        gold.append(g)
        det.append(d)
        scores.append(rng.random(len(d)))
    ap50, ap = coco_ap(gold, det, scores)
    want50 = _ap_101(gold, det, scores, 0.5)
    want = np.mean([_ap_101(gold, det, scores, t) for t in np.linspace(0.5, 0.95, 10)])
    assert ap50 == pytest.approx(want50, abs=1e-9)
    assert ap == pytest.approx(want, abs=1e-9)
    assert 0.0 < ap < ap50 < 1.0


def test_hand_computed_ap_one_hit_one_false_positive():
    g = [np.array([[0, 0, 10, 10], [50, 50, 60, 60]], float)]
    d = [np.array([[0, 0, 10, 10], [100, 100, 110, 110]], float)]
    ap50, _ = coco_ap(g, d, [np.array([0.9, 0.8])])
    assert ap50 == pytest.approx(51 / 101)  # precision 1 up to recall 0.5, then nothing


def test_hungarian_match_keeps_pairs_over_the_threshold_only():
    gold = np.array([[0, 0, 10, 10], [20, 0, 30, 10], [100, 100, 110, 110]], float)
    det = np.array([[21, 0, 31, 10], [0, 0, 10, 10], [104, 104, 114, 114]], float)
    assert hungarian_match(gold, det).tolist() == [1, 0, -1]
    assert hungarian_match(gold, np.zeros((0, 4))).tolist() == [-1, -1, -1]


def test_detections_file_round_trip_and_line_numbered_errors(tmp_path: Path):
    dets = [Detections("a", np.array([[1.0, 2, 3, 4]]), np.array([0.5]), ("cube",), ("red",)),
            Detections("b", np.zeros((0, 4)), np.zeros(0))]
    path = write_detections(tmp_path / "d.jsonl", "smoke-v2/test", "x-v1", dets)
    back = read_detections(path)
    assert back.detector == "x-v1" and set(back.by_id) == {"a", "b"}
    assert back.by_id["a"].shapes == ("cube",) and len(back.by_id["b"]) == 0
    lines = path.read_text().splitlines()
    bad = json.loads(lines[1])
    bad["boxes"][0] = [5, 2, 3, 4]
    bad["colours"] = ["mauve"]
    lines[1] = json.dumps(bad)
    lines.append(json.dumps({"id": "b", "boxes": [], "scores": []}))
    lines.append("{not json")
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(SubmissionError) as err:
        read_detections(path)
    text = str(err.value)
    assert "line 2: boxes[0]" in text and "'mauve'" in text
    assert "line 4: duplicate id 'b'" in text and "line 5: invalid JSON" in text


def test_detection_scores_count_missed_and_merged_objects(smoke_v2_test: Path):
    gold = gold_scenes(smoke_v2_test)
    perfect = {g.id: Detections(g.id, g.boxes, np.ones(len(g.boxes)), g.shapes, g.colours)
               for g in gold}
    s = score_detections(gold, perfect)
    assert (s.ap50, s.recall, s.failure_share, s.shape_accuracy) == (1.0, 1.0, 0.0, 1.0)
    g0, g1 = gold[0], gold[1]
    worse = dict(perfect)
    worse[g0.id] = Detections(g0.id, g0.boxes[1:], np.ones(len(g0.boxes) - 1))
    union = np.concatenate([np.minimum(g1.boxes[0, :2], g1.boxes[1, :2]),
                            np.maximum(g1.boxes[0, 2:], g1.boxes[1, 2:])])
    merged_boxes = np.concatenate([g1.boxes[:1] * 0 + union, g1.boxes[2:]])
    worse[g1.id] = Detections(g1.id, merged_boxes, np.ones(len(merged_boxes)))
    s = score_detections(gold, worse)
    assert s.failure_share == pytest.approx(2 / len(gold))
    assert s.missed + s.merged == 1 + (2 - int((pairwise_iou(union[None], g1.boxes[:2])
                                                >= 0.5).sum()))
    assert s.recall < 1.0 and s.ap50 < 1.0


def test_classical_detector_finds_the_smoke_objects(tmp_path: Path, smoke_v2_test: Path):
    from nsrmp_bench.detection.part_detection import detect_part

    det_id, out, n, _ = detect_part("classical", smoke_v2_test, tmp_path / "c.jsonl")
    assert det_id == "classical-v1" and n == 16
    s = score_detections(gold_scenes(smoke_v2_test), read_detections(out).by_id)
    assert s.ap50 >= 0.9 and s.recall >= 0.9 and s.colour_accuracy >= 0.95
