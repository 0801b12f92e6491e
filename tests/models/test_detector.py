"""The learned detector: a tiny training run learns to find objects (far above detecting
nothing), is byte-deterministic, and its detections feed NSRM through predict --boxes,
written in the detected-objects protocol that the public scorer scores."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("torch")
pytest.importorskip("scipy")
pytest.importorskip("pycocotools")



@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory: pytest.TempPathFactory, tiny_paper: Path) -> Path:
    from nsrmp_bench.reference_model.detector import DetectorConfig, DetectorPredictor

    cfg = DetectorConfig(epochs=4, train_limit=192, val_limit=24, batch_size=16)
    return DetectorPredictor.train(tiny_paper, tmp_path_factory.mktemp("det") / "run", seed=0,
                                   config=cfg, quiet=True)


@pytest.mark.slow
def test_tiny_training_learns_to_detect(tiny_run: Path, smoke_test: Path):
    from nsrmp_bench.detection.metrics import gold_scenes, score_detections
    from nsrmp_bench.reference_model.detector import DetectorPredictor

    dets = {d.id: d for d in DetectorPredictor.from_checkpoint(tiny_run).detect_part(smoke_test)}
    s = score_detections(gold_scenes(smoke_test), dets)
    # detecting nothing scores 0 on both; a random box almost never reaches IoU 0.5
    assert s.recall >= 0.5 and s.ap50 >= 0.4, s
    card = json.loads((tiny_run.parent / "card.json").read_text())
    assert card["model"] == "detector-v1" and card["parameters"] > 0


@pytest.mark.slow
def test_same_seed_and_data_give_the_same_bytes(tmp_path: Path, tiny_paper: Path):
    from nsrmp_bench.reference_model.detector import DetectorConfig, DetectorPredictor

    cfg = DetectorConfig(epochs=1, train_limit=32, val_limit=4, batch_size=16)
    a = DetectorPredictor.train(tiny_paper, tmp_path / "a", seed=3, config=cfg, quiet=True)
    b = DetectorPredictor.train(tiny_paper, tmp_path / "b", seed=3, config=cfg, quiet=True)
    assert a.read_bytes() == b.read_bytes()


@pytest.mark.slow
def test_nsrm_reads_detected_boxes_and_the_scorer_matches_them(tiny_run: Path,
                                                               tmp_path: Path,
                                                               smoke_test: Path):
    from nsrmp_bench.detection.metrics import gold_scenes
    from nsrmp_bench.detection.part_detection import detect_part
    from nsrmp_bench.reference_model.detector import detect_with
    from nsrmp_bench.reference_model.part_prediction import predict_part
    from nsrmp_bench.scoring import score

    det_id, dfile, n, _ = detect_part("learned", smoke_test, tmp_path / "d.jsonl", tiny_run,
                                      detect_with)
    assert det_id == "detector-v1" and n == 16
    model_id, pred, _ = predict_part("nsrm-v2", smoke_test, tmp_path / "p.jsonl", boxes=dfile)
    assert model_id == "nsrm-v2+detector-v1"
    lines = [json.loads(x) for x in pred.read_text().splitlines()]
    assert lines[0]["header"]["boxes"] == "detector-v1"
    assert all(len(r["detections"]) == len(r["boxes"]) for r in lines[1:])
    result = score(pred, smoke_test, n_boot=0)
    c = result.counts
    n_gold = sum(len(g.boxes) for g in gold_scenes(smoke_test))
    assert c["detected_lines"] == 16
    assert c["detected_objects_matched"] + c["detected_objects_unmatched"] == n_gold
    assert c["detected_objects_matched"] > n_gold // 2
