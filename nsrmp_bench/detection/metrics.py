"""Detection metrics of a detections file against a split part's gold initial boxes.

- ``ap50``, ``ap``: COCO box AP at IoU 0.5 and averaged over IoU 0.50:0.05:0.95, one
  class ("object"), computed by pycocotools' ``COCOeval`` (the reference implementation:
  101-point interpolated precision, greedy score-ordered matching, maxDets 100);
- ``recall``: the share of gold objects matched by a detection (Hungarian on IoU,
  threshold :data:`~nsrmp_bench.scoring.matching.MATCH_IOU`), ``precision`` the share
  of detections matched;
- ``failure_share``: the share of scenes with at least one unmatched gold object; an
  unmatched object is *merged* when its box centre lies inside a detection matched to
  another object (two objects seen as one), else *missed*;
- ``shape_accuracy``, ``colour_accuracy``: over matched detections that name one.

An episode without a line has nothing detected (all its objects missed). Needs scipy and
pycocotools (the ``detection`` extra), not torch.
"""

from __future__ import annotations

import contextlib
import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require
from nsrmp_bench.detection.detections import Detections
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scoring.matching import MATCH_IOU, hungarian_match

__all__ = ["DetectionScores", "GoldScene", "coco_ap", "gold_scenes", "score_detections"]


@dataclass(frozen=True)
class GoldScene:
    """One episode's gold initial objects."""

    id: str
    boxes: NDArray[np.float64]  # (N, 4)
    shapes: tuple[str, ...]
    colours: tuple[str, ...]


@dataclass(frozen=True)
class DetectionScores:
    """The figures of one detections file on one part."""

    ap50: float
    ap: float
    recall: float
    precision: float
    failure_share: float
    missed: int
    merged: int
    shape_accuracy: float
    colour_accuracy: float
    scenes: int
    objects: int
    detections: int
    missing_lines: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        return dict(self.__dict__)


def coco_ap(gold: Sequence[NDArray[Any]], detected: Sequence[NDArray[Any]],
            scores: Sequence[NDArray[Any]]) -> tuple[float, float]:
    """COCO (AP@0.5, AP@[.5:.95]) of per-image detections (pycocotools, one class)."""
    coco_mod = require("pycocotools.coco")
    eval_mod = require("pycocotools.cocoeval")
    images: list[dict[str, Any]] = []
    anns: list[dict[str, Any]] = []
    dets: list[dict[str, Any]] = []
    for i, (g, d, s) in enumerate(zip(gold, detected, scores, strict=True)):
        images.append({"id": i + 1, "width": 1, "height": 1})
        for b in np.asarray(g, float).reshape(-1, 4):
            w, h = float(b[2] - b[0]), float(b[3] - b[1])
            anns.append({"id": len(anns) + 1, "image_id": i + 1, "category_id": 1,
                         "bbox": [float(b[0]), float(b[1]), w, h], "area": w * h,
                         "iscrowd": 0})
        for b, sc in zip(np.asarray(d, float).reshape(-1, 4), np.asarray(s, float),
                         strict=True):
            dets.append({"image_id": i + 1, "category_id": 1, "score": float(sc),
                         "bbox": [float(b[0]), float(b[1]), float(b[2] - b[0]),
                                  float(b[3] - b[1])]})
    if not anns:
        return float("nan"), float("nan")
    if not dets:
        return 0.0, 0.0
    with contextlib.redirect_stdout(io.StringIO()):  # pycocotools prints as it goes
        gt = coco_mod.COCO()
        gt.dataset = {"images": images, "annotations": anns,
                      "categories": [{"id": 1, "name": "object"}]}
        gt.createIndex()
        dt = gt.loadRes(dets)
        ev = eval_mod.COCOeval(gt, dt, iouType="bbox")
        ev.params.areaRng = [[0.0, 1e10]]  # one area range: all objects
        ev.params.areaRngLbl = ["all"]
        ev.evaluate()
        ev.accumulate()
    prec = ev.eval["precision"][:, :, 0, 0, -1]  # (iou thresholds, recall points)
    valid = prec > -1
    per_iou = [float(p[v].mean()) if v.any() else 0.0 for p, v in zip(prec, valid, strict=True)]
    return per_iou[0], float(np.mean(per_iou))


def score_detections(gold: Sequence[GoldScene], detections: dict[str, Detections],
                     threshold: float = MATCH_IOU) -> DetectionScores:
    """The figures of ``detections`` (by episode id) on the ``gold`` scenes."""
    empty = np.zeros((0, 4))
    det_boxes, det_scores = [], []
    matched = missed = merged = failed = n_det = missing = 0
    shape_ok = shape_n = colour_ok = colour_n = 0
    for g in gold:
        d = detections.get(g.id)
        if d is None:
            missing += 1
        boxes = d.boxes if d is not None else empty
        det_boxes.append(boxes)
        det_scores.append(d.scores if d is not None else np.zeros(0))
        n_det += len(boxes)
        m = hungarian_match(g.boxes, boxes, threshold)
        hit = m >= 0
        matched += int(hit.sum())
        if not hit.all():
            failed += 1
            centres = (g.boxes[~hit, :2] + g.boxes[~hit, 2:]) / 2
            used = boxes[m[hit]]
            inside = ((centres[:, None, 0] >= used[None, :, 0])
                      & (centres[:, None, 0] <= used[None, :, 2])
                      & (centres[:, None, 1] >= used[None, :, 1])
                      & (centres[:, None, 1] <= used[None, :, 3])).any(1)
            merged += int(inside.sum())
            missed += int((~inside).sum())
        if d is not None:
            for gi in np.flatnonzero(hit):
                s, c = d.shapes[m[gi]], d.colours[m[gi]]
                if s is not None:
                    shape_n += 1
                    shape_ok += int(s == g.shapes[gi])
                if c is not None:
                    colour_n += 1
                    colour_ok += int(c == g.colours[gi])
    ap50, ap = coco_ap([g.boxes for g in gold], det_boxes, det_scores)
    n_obj = sum(len(g.boxes) for g in gold)
    nan = float("nan")
    return DetectionScores(
        ap50=ap50, ap=ap, recall=matched / max(1, n_obj),
        precision=matched / n_det if n_det else nan,
        failure_share=failed / max(1, len(gold)), missed=missed, merged=merged,
        shape_accuracy=shape_ok / shape_n if shape_n else nan,
        colour_accuracy=colour_ok / colour_n if colour_n else nan,
        scenes=len(gold), objects=n_obj, detections=n_det, missing_lines=missing)


def gold_scenes(data: str | Path, split: str | None = None) -> list[GoldScene]:
    """The gold initial objects of every episode of a part (no images read).

    ``split``, when given (a detections header's), must name the data's split.
    """
    from nsrmp_bench.scoring.align import split_matches
    from nsrmp_bench.storage.reader import open as open_collection
    from nsrmp_bench.storage.split_root import part_of_split, resolve_part

    col = open_collection(resolve_part(data, part_of_split(split) if split else None))
    if split and col.split and not split_matches(split, col.split):
        msg = (f"the detections are for split {split!r} but {data} is split {col.split!r}; "
               "score them against the data they were made on")
        raise InvalidArgument(msg)
    out = []
    for i in range(len(col)):
        inp = col.read_inputs(i, images=False)
        tg = col.read_targets(i, arrays=())
        if inp["boxes"] is None:
            msg = f"episode {inp['id']!r} of {data} has no rendering, so no boxes to detect"
            raise InvalidArgument(msg)
        objs = tg["symbolic"]["scene"]["objects"]
        out.append(GoldScene(str(inp["id"]), np.asarray(inp["boxes"], dtype=np.float64),
                             tuple(o["shape"] for o in objs), tuple(o["colour"] for o in objs)))
    col.close()
    return out
