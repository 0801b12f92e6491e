"""``nsrmp-bench score-detections``: detection metrics of a detections file.

Example::

    nsrmp-bench score-detections detections.jsonl --data data/paper-v2/test [--json d.json]

Prints COCO AP@0.5 and AP@[.5:.95] (pycocotools), recall and precision at IoU 0.5
(Hungarian matching), the share of scenes with a missed or merged object, and the shape
and colour accuracy of matched detections (definitions in
``nsrmp_bench/detection/metrics.py``). Needs the ``detection`` extra, not torch.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from nsrmp_bench.storage.atomic import atomic_write_text, output_file

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("detections", type=Path, help="detections file (.jsonl)")
    parser.add_argument("--data", required=True, type=Path,
                        help="the split part it was made on (e.g. data/paper-v2/test)")
    parser.add_argument("--json", type=output_file, default=None,
                        help="also write the figures here")


def run(args: argparse.Namespace) -> int:
    """Score and print."""
    from nsrmp_bench.detection.detections import read_detections
    from nsrmp_bench.detection.metrics import gold_scenes, score_detections

    found = read_detections(args.detections)
    scores = score_detections(gold_scenes(args.data, found.header.get("split")), found.by_id)
    d = scores.to_dict()
    print(f"{found.detector} on {args.data}: {d['scenes']} scenes, {d['objects']} objects, "
          f"{d['detections']} detections")
    for key, label in (("ap50", "AP@0.5"), ("ap", "AP@[.5:.95]"), ("recall", "recall@0.5"),
                       ("precision", "precision@0.5"), ("failure_share", "failed scenes"),
                       ("shape_accuracy", "shape acc."), ("colour_accuracy", "colour acc.")):
        print(f"  {label:<14} {d[key]:.4f}")
    print(f"  missed {d['missed']}, merged {d['merged']}, episodes without a line "
          f"{d['missing_lines']}")
    if args.json is not None:
        atomic_write_text(args.json, json.dumps(
            {"detector": found.detector, "data": str(args.data), **d}, indent=1) + "\n")
    return 0
