"""A small CenterNet-style detector, from scratch in plain torch.

Input: RGB and the height above the table (4 channels, full image). Output at stride 4:
one class-agnostic centre heatmap, the box size and the sub-cell centre offset, and shape
and colour logits. Decoding takes the heatmap's local maxima (3x3 max-pool), so no NMS is
needed.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nsrmp_bench.vocabulary import COLOURS, SHAPES

__all__ = ["STRIDE", "CenterNet", "Decoded", "decode", "image_tensor"]

STRIDE = 4
HEIGHT_SCALE = 10.0  # metres above the table -> input units (a cube's top ~0.5)
_HEADS = 1 + 2 + 2 + len(SHAPES) + len(COLOURS)  # heat, size, offset, shape, colour


def _conv(cin: int, cout: int, stride: int = 1, dilation: int = 1) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(cin, cout, 3, stride=stride, padding=dilation, dilation=dilation,
                  bias=False),
        nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


def image_tensor(rgb: Tensor, height: Tensor) -> Tensor:
    """(B, H, W, 3) uint8 and (B, H, W) float metres -> the (B, 4, H, W) network input."""
    x = rgb.permute(0, 3, 1, 2).float() / 255.0 - 0.5
    h = (height.float() * HEIGHT_SCALE).clamp(-1.0, 3.0).unsqueeze(1)
    return torch.cat([x, h], dim=1)


class CenterNet(nn.Module):
    """Stride-4 dense heads over a three-level backbone with one skip."""

    def __init__(self, width: int = 32) -> None:
        super().__init__()
        w8 = width * 3 // 2
        self.stem = nn.Sequential(_conv(4, 16, 2), _conv(16, width, 2), _conv(width, width))
        self.down = nn.Sequential(_conv(width, w8, 2), _conv(w8, w8, dilation=2),
                                  _conv(w8, w8, dilation=4))
        self.fuse = nn.Sequential(
            nn.Conv2d(width + w8, width, 1, bias=False), nn.BatchNorm2d(width),
            nn.ReLU(inplace=True), _conv(width, width))
        self.head = nn.Conv2d(width, _HEADS, 1)
        prior = torch.zeros(_HEADS)
        prior[0] = -2.19  # CenterNet's prior: few cells are centres
        self.head.bias = nn.Parameter(prior)

    def forward(self, x: Tensor) -> Tensor:
        s4 = self.stem(x)
        s8 = self.down(s4)
        up = F.interpolate(s8, size=s4.shape[-2:], mode="nearest")
        out: Tensor = self.head(self.fuse(torch.cat([s4, up], dim=1)))
        return out


@dataclass(frozen=True)
class Decoded:
    """One image's detections: boxes (K, 4) pixel xyxy, scores, shape and colour indices
    and their probabilities."""

    boxes: Tensor
    scores: Tensor
    shapes: Tensor
    colours: Tensor
    shape_scores: Tensor
    colour_scores: Tensor


def decode(out: Tensor, threshold: float, max_detections: int) -> list[Decoded]:
    """Peaks of the heatmap (3x3 local maxima at or above ``threshold``) as detections."""
    heat = torch.sigmoid(out[:, 0])
    peaks = heat == F.max_pool2d(heat.unsqueeze(1), 3, 1, 1).squeeze(1)
    ns = len(SHAPES)
    result = []
    for b in range(out.shape[0]):
        hb = torch.where(peaks[b], heat[b], torch.zeros_like(heat[b]))
        flat = hb.flatten()
        k = min(max_detections, flat.numel())
        scores, idx = flat.topk(k)
        keep = scores >= threshold
        scores, idx = scores[keep], idx[keep]
        wdt = out.shape[-1]
        ys, xs = (idx // wdt).float(), (idx % wdt).float()
        o = out[b].flatten(1)[:, idx]  # (C, K)
        cx = (xs + 0.5 + o[3]) * STRIDE
        cy = (ys + 0.5 + o[4]) * STRIDE
        bw, bh = o[1].exp() * STRIDE, o[2].exp() * STRIDE
        boxes = torch.stack([cx - bw / 2, cy - bh / 2, cx + bw / 2, cy + bh / 2], dim=1)
        sp = torch.softmax(o[5:5 + ns].T, dim=1)
        cp = torch.softmax(o[5 + ns:].T, dim=1)
        result.append(Decoded(boxes, scores, sp.argmax(1), cp.argmax(1), sp.max(1).values,
                              cp.max(1).values))
    return result
