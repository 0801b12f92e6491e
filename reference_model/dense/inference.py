"""The dense network at inference: heatmap argmax to a pick and a place, and the boxes.

The pick is the argmax cell of the pick heatmap; the picked object is the initial box
that holds that point (the one whose centre is nearest if several or none do), and the
pick reported is that box's centre (the point the transport was trained to be given).
The place is the centre of the argmax cell of the place heatmap given that pick. The
predicted final boxes are the initial boxes with the picked one moved so that its centre
lands on the place (clipped to the image).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from nsrmp_bench.reference_model.dense.inputs import DenseInputs, cell_centres, cells_of
from nsrmp_bench.reference_model.dense.transport import TransportNet

__all__ = ["Inferred", "infer", "moved_boxes", "picked_object"]


@dataclass
class Inferred:
    """Per episode: the picked object, the pick and place points and the final boxes."""

    subjects: list[int]
    picks: np.ndarray[Any, Any]  # (E, 2) pixels
    places: np.ndarray[Any, Any]  # (E, 2) pixels
    boxes: list[np.ndarray[Any, Any]]  # per episode (N, 4)


def picked_object(point: np.ndarray[Any, Any], boxes: np.ndarray[Any, Any]) -> int:
    """The box holding ``point`` (nearest centre among several, or among all if none)."""
    centres = np.stack([(boxes[:, 0] + boxes[:, 2]) / 2, (boxes[:, 1] + boxes[:, 3]) / 2], 1)
    dist = np.linalg.norm(centres - point[None], axis=1)
    inside = ((boxes[:, 0] <= point[0]) & (point[0] <= boxes[:, 2])
              & (boxes[:, 1] <= point[1]) & (point[1] <= boxes[:, 3]))
    if inside.any():
        dist = np.where(inside, dist, np.inf)
    return int(np.argmin(dist))


def moved_boxes(boxes: np.ndarray[Any, Any], subject: int, place: np.ndarray[Any, Any],
                size: tuple[int, int]) -> np.ndarray[Any, Any]:
    """``boxes`` with box ``subject`` moved so its centre is ``place`` (clipped to
    ``size``, width and height)."""
    out = boxes.copy()
    b = out[subject]
    shift = place - np.array([(b[0] + b[2]) / 2, (b[1] + b[3]) / 2])
    out[subject] = b + np.array([shift[0], shift[1], shift[0], shift[1]])
    limit = np.array([size[0], size[1], size[0], size[1]], dtype=np.float64)
    clipped: np.ndarray[Any, Any] = np.clip(out, 0.0, limit)
    return clipped


@torch.no_grad()
def infer(model: TransportNet, enc: DenseInputs, batch_size: int = 64) -> Inferred:
    """Pick, place and final boxes of every episode of ``enc`` (model in eval mode)."""
    model.eval()
    subjects: list[int] = []
    picks, places = [], []
    for lo in range(0, len(enc), batch_size):
        rows = torch.arange(lo, min(lo + batch_size, len(enc)))
        x = model.image_input(enc.image(rows))
        text = model.text(enc.tokens_of(rows))
        peak = cell_centres(model.pick_logits(x, text).argmax(1), enc)
        chosen = [picked_object(p, enc.boxes[int(r)]) for p, r in zip(peak, rows, strict=True)]
        pick = np.stack([_centre(enc.boxes[int(r)][s]) for r, s in zip(rows, chosen,
                                                                       strict=True)])
        place = cell_centres(model.place_logits(x, text, cells_of(pick, enc)).argmax(1), enc)
        subjects += chosen
        picks.append(pick)
        places.append(place)
    pk, pl = np.concatenate(picks), np.concatenate(places)
    boxes = [moved_boxes(enc.boxes[i], subjects[i], pl[i], enc.image_size) for i in range(len(enc))]
    return Inferred(subjects, pk, pl, boxes)


def _centre(box: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
    return np.array([(box[0] + box[2]) / 2, (box[1] + box[3]) / 2], dtype=np.float64)
