"""The detector's targets and loss (CenterNet's): a Gaussian-splatted centre heatmap with
the penalty-reduced focal loss, L1 on log box size and centre offset at the centre cells,
and cross-entropy on shape and colour there."""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

from nsrmp_bench.reference_model.detector.model import STRIDE
from nsrmp_bench.vocabulary import SHAPES

__all__ = ["detection_loss"]


def _heatmap(boxes: Tensor, h: int, w: int) -> tuple[Tensor, Tensor, Tensor]:
    """Heatmap (h, w), centre cells (K, 2) as (x, y) ints and their boxes' centres/stride."""
    heat = torch.zeros((h, w))
    if len(boxes) == 0:
        return heat, torch.zeros((0, 2), dtype=torch.long), torch.zeros((0, 2))
    c = torch.stack([(boxes[:, 0] + boxes[:, 2]) / 2, (boxes[:, 1] + boxes[:, 3]) / 2], 1)
    c = c / STRIDE
    cell = c.floor().long()
    ys = torch.arange(h).float()[:, None]
    xs = torch.arange(w).float()[None, :]
    size = torch.stack([boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1]], 1) / STRIDE
    sigma = (size.min(1).values / 6.0).clamp(min=0.7)
    for (cx, cy), s in zip(cell.tolist(), sigma.tolist(), strict=True):
        g = torch.exp(-((xs - cx) ** 2 + (ys - cy) ** 2) / (2 * s * s))
        heat = torch.maximum(heat, g)
    return heat, cell, c


def detection_loss(out: Tensor, boxes: list[Tensor], shapes: list[Tensor],
                   colours: list[Tensor]) -> Tensor:
    """Loss of the network output ``out`` (B, C, h, w) against each image's gold boxes (in
    the crop's pixels), shape and colour indices; objects whose centre lies outside the
    crop are left out."""
    b, _, h, w = out.shape
    heats, terms, n_obj = [], [], 0
    size_l = torch.zeros(())
    cls_l = torch.zeros(())
    ns = len(SHAPES)
    for i in range(b):
        bx = boxes[i]
        cxy = torch.stack([(bx[:, 0] + bx[:, 2]) / 2, (bx[:, 1] + bx[:, 3]) / 2], 1)
        inside = ((cxy[:, 0] >= 0) & (cxy[:, 0] < w * STRIDE)
                  & (cxy[:, 1] >= 0) & (cxy[:, 1] < h * STRIDE))
        bx = bx[inside]
        heat, cell, c = _heatmap(bx, h, w)
        heats.append(heat)
        if len(bx) == 0:
            continue
        o = out[i][:, cell[:, 1], cell[:, 0]]  # (C, K)
        size = torch.stack([bx[:, 2] - bx[:, 0], bx[:, 3] - bx[:, 1]], 1).clamp(min=1.0)
        log_size = (size / STRIDE).log()
        offset = c - cell.float() - 0.5
        size_l = size_l + F.l1_loss(o[1:3].T, log_size, reduction="sum")
        size_l = size_l + F.l1_loss(o[3:5].T, offset, reduction="sum")
        cls_l = cls_l + F.cross_entropy(o[5:5 + ns].T, shapes[i][inside], reduction="sum")
        cls_l = cls_l + F.cross_entropy(o[5 + ns:].T, colours[i][inside], reduction="sum")
        n_obj += len(bx)
    gt = torch.stack(heats)
    p = torch.sigmoid(out[:, 0]).clamp(1e-4, 1 - 1e-4)
    pos = gt.eq(1.0).float()  # the centre cells
    pos_l = -(torch.log(p) * (1 - p) ** 2 * pos).sum()
    neg_l = -(torch.log(1 - p) * p ** 2 * (1 - gt) ** 4 * (1 - pos)).sum()
    norm = max(1, n_obj)
    terms.append((pos_l + neg_l) / norm)
    terms.append(size_l / norm)
    terms.append(0.5 * cls_l / norm)
    return torch.stack(terms).sum()
