"""Figures of the detectors and of models on extracted boxes (Table I, "extracted BB").

Usage::

    .venv/bin/python benchmarks/bench_detection.py --data-root data [--parts paper-v2/test
        objects-v2/test] [--detectors learned classical] [--models nsrm nmn]
        [--out runs/detection] [--leaderboard]

For each test part and detector: ``nsrmp-bench detect`` (timed: images/s, reading the
images included, and the detector alone), ``nsrmp-bench score-detections`` (COCO AP@0.5
and AP@[.5:.95], recall, failed scenes). Then for each model and detector:
``nsrmp-bench predict MODEL --boxes DETECTIONS`` and ``nsrmp-bench score`` (IoU-M and IoU
with every failure scored 0), beside the model on gold boxes (its committed leaderboard
predictions where there are some, else predicted here) and the paper's rows. A detections
file already in ``--out`` is not made again (delete it to re-time the detector).
``--leaderboard`` copies the predictions into ``leaderboards/predictions/`` and writes an
entry ``leaderboards/entries/<split>-<part>--<model>+<detector>.json`` for each.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

from nsrmp_bench.reference_model.registry import get_model
from nsrmp_bench.scoring.file_formats import read_jsonl_bytes, write_jsonl_bytes
from nsrmp_bench.scoring.reader import read_header

PAPER = {  # Table I, extracted BB: IoU-M, with ~10% of scenes excluded (paper split only)
    "nsrm": "0.41 (10% excluded)",
    "nmn": "0.32 (10% excluded)",
}
DETECTOR_IDS = {"learned": "detector-v1", "classical": "classical-v1"}
LEADERBOARD = Path(__file__).resolve().parents[1] / "leaderboards"


def _cli(*args: str) -> str:
    exe = Path(sys.executable).with_name("nsrmp-bench")
    done = subprocess.run([str(exe), *args], check=True, capture_output=True, text=True)
    return done.stdout


def _score(pred: Path, data: Path, out: Path) -> dict[str, float]:
    _cli("score", str(pred), "--data", str(data), "--json", str(out))
    summary = json.loads(out.read_text())["summary"]
    rows = summary if isinstance(summary, dict) else {r["metric"]: r for r in summary}
    return {k: float(rows[k]["value"]) for k in ("iou_m", "iou", "subject_all_steps")}


def throughput(detector: str, data: Path, n: int = 64) -> dict[str, float]:
    """The detector alone on (up to) ``n`` images already in memory: images per wall second and
    per process CPU second (on a shared machine the CPU figure is the stable one; a quiet
    2-core machine runs the learned detector's 2 threads at about twice it)."""
    from nsrmp_bench.storage.reader import input_camera
    from nsrmp_bench.storage.reader import open as open_collection

    if detector == "learned":
        from nsrmp_bench.dataset import EpisodeDataset
        from nsrmp_bench.reference_model.checkpoints import shipped_checkpoint
        from nsrmp_bench.reference_model.detector import DetectorPredictor, detect_scenes
        from nsrmp_bench.reference_model.detector.scenes import read_scenes

        model = DetectorPredictor.from_checkpoint(shipped_checkpoint("detector-v1"))
        ds = EpisodeDataset(data)
        scenes = read_scenes(ds.iter_items(n), targets=False)
        model.detect(ds.iter_items(8))  # warm up
        t0, c0 = time.perf_counter(), time.process_time()
        detect_scenes(model.model, scenes, model.config)
        count = len(scenes)
    else:
        from nsrmp_bench.detection.classical import classical_detect

        col = open_collection(data)
        inputs = [col.read_inputs(i) for i in range(min(n, len(col)))]
        t0, c0 = time.perf_counter(), time.process_time()
        for x in inputs:
            classical_detect(str(x["id"]), x["rgb"], x["depth"], input_camera(x, x["id"]))
        count = len(inputs)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"images_per_wall_s": count / wall, "images_per_cpu_s": count / cpu}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data-root", type=Path, required=True)
    ap.add_argument("--parts", nargs="+", default=["paper-v2/test", "objects-v2/test"])
    ap.add_argument("--detectors", nargs="+", default=["learned", "classical"])
    ap.add_argument("--models", nargs="+", default=["nsrm"])
    ap.add_argument("--out", type=Path, default=Path("runs/detection"))
    ap.add_argument("--leaderboard", action="store_true")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    report: dict[str, object] = {}
    det_rows, model_rows = [], []
    for part in args.parts:
        data = args.data_root / part
        if not (data / "manifest.json").exists():
            print(f"-- {part}: no data at {data}, skipped")
            continue
        tag = part.replace("/", "-")
        for det in args.detectors:
            dfile = args.out / f"{tag}--{DETECTOR_IDS[det]}.jsonl"
            timing = dfile.with_suffix(".timing.json")
            if not dfile.exists():
                t0 = time.perf_counter()
                line = _cli("detect", "--data", str(data), "--out", str(dfile), "--detector",
                            det)
                rate = float(line.split("s, ")[-1].split(" images/s")[0])
                timing.write_text(json.dumps({"images_per_s_with_reading": rate,
                                              "command_wall_s": time.perf_counter() - t0}))
            js = args.out / f"{tag}--{DETECTOR_IDS[det]}.scores.json"
            _cli("score-detections", str(dfile), "--data", str(data), "--json", str(js))
            s = json.loads(js.read_text())
            s.update(json.loads(timing.read_text()) if timing.exists()
                     else {"images_per_s_with_reading": float("nan")})
            s.update(throughput(det, data))
            report[f"{tag}--{DETECTOR_IDS[det]}"] = s
            det_rows.append((part, DETECTOR_IDS[det], s))
            for model in args.models:
                mid = get_model(model).id
                pred = args.out / f"{tag}--{mid}+{DETECTOR_IDS[det]}.jsonl"
                if not pred.exists():
                    _cli("predict", model, "--boxes", str(dfile), "--data", str(data),
                         "--out", str(pred), "--quiet")
                sc = _score(pred, data, pred.with_suffix(".scores.json"))
                committed = LEADERBOARD / "predictions" / f"{tag}--{mid}.jsonl.gz"
                gold_pred = (committed if committed.exists()
                             else args.out / f"{tag}--{model}-gold.jsonl")
                if not gold_pred.exists():
                    _cli("predict", model, "--data", str(data), "--out", str(gold_pred),
                         "--quiet")
                gold = _score(gold_pred, data, args.out / f"{tag}--{model}-gold.scores.json")
                model_rows.append((part, model, DETECTOR_IDS[det], sc, gold))
                report[f"{tag}--{model}+{DETECTOR_IDS[det]}"] = {"extracted": sc, "gold": gold}
                if args.leaderboard:
                    _entry(part, model, DETECTOR_IDS[det], pred)
    print("\nDetectors (AP by pycocotools; recall and failed scenes at IoU 0.5, Hungarian)")
    print("| part | detector | AP@0.5 | AP@[.5:.95] | recall | failed scenes | "
          "missed / merged | images/s (with reading) | images/s alone | images per CPU s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for part, det, s in det_rows:
        print(f"| {part} | {det} | {s['ap50']:.3f} | {s['ap']:.3f} | {s['recall']:.3f} | "
              f"{s['failure_share']:.3f} | {s['missed']} / {s['merged']} | "
              f"{s['images_per_s_with_reading']:.1f} | {s['images_per_wall_s']:.1f} | "
              f"{s['images_per_cpu_s']:.1f} |")
    print("\nTable I, extracted BB (failures scored 0, nothing excluded)")
    print("| part | model | boxes | IoU-M | IoU | subject (all steps) | gold-box IoU-M | "
          "paper IoU-M |")
    print("|---|---|---|---|---|---|---|---|")
    for part, model, det, sc, gold in model_rows:
        print(f"| {part} | {model} | {det} | {sc['iou_m']:.3f} | {sc['iou']:.3f} | "
              f"{sc['subject_all_steps']:.3f} | {gold['iou_m']:.3f} | "
              f"{PAPER.get(model, '-') if part.startswith('paper-') else '-'} |")
    (args.out / "report.json").write_text(json.dumps(report, indent=1) + "\n", "utf-8")
    return 0


def _entry(part: str, model: str, detector: str, pred: Path) -> None:
    tag = part.replace("/", "-")
    head = read_header(pred)
    model_id = str(head["model"])
    root = LEADERBOARD
    dest = root / "predictions" / f"{tag}--{model_id}.jsonl.gz"
    write_jsonl_bytes(dest, read_jsonl_bytes(pred))
    entry = {
        "model": model_id,
        "split": part,
        "predictions": f"../predictions/{dest.name}",
        "kind": "reference",
        "description": f"{model} (shipped checkpoint) on boxes extracted by {detector} "
                       "(nsrmp-bench detect), not gold boxes: the detected-objects protocol, "
                       "unmatched objects scored IoU 0, nothing excluded",
        "boxes": detector,
        "model_card": "../../reference_model/detector/MODEL_CARD.md",
    }
    (root / "entries" / f"{tag}--{model_id}.json").write_text(
        json.dumps(entry, indent=1) + "\n", "utf-8")


if __name__ == "__main__":
    raise SystemExit(main())
