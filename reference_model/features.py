"""Object inputs shared by the object-centric models: crops, colour statistics, geometry.

Everything here is computed from what ``EpisodeDataset`` gives as ``inputs`` (the initial
RGB, depth and boxes) and nothing else. Per object:

- ``crop``: the RGB inside its box (10% margin), resized to ``CROP`` x ``CROP``, uint8;
- ``geometry``: box centre and size normalised by the image size, and the median depth of
  the central half of the box (metres), as ``[cx, cy, w, h, depth]``.

:class:`CropEncoder` is the small from-scratch CNN (no pretrained weights can be had here)
that turns crops into features; it appends the crop's mean and spread of colour, which
lets colour concepts be grounded at once while the convolutions learn shape.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from numpy.typing import NDArray
from torch import Tensor, nn

__all__ = ["CROP", "GEOMETRY", "CropEncoder", "ObjectInputs", "object_inputs"]

CROP = 32
GEOMETRY = 5
_MARGIN = 0.10


@dataclass(frozen=True)
class ObjectInputs:
    """One episode's objects: ``crops`` (N, 3, CROP, CROP) uint8, ``geometry`` (N, 5)."""

    crops: NDArray[np.uint8]
    geometry: NDArray[np.float32]
    boxes: NDArray[np.float32]  # (N, 4) pixel xyxy, as given
    image_size: tuple[int, int]  # (width, height)


def object_inputs(rgb: NDArray[Any], depth: NDArray[Any], boxes: NDArray[Any]) -> ObjectInputs:
    """Crops and geometry of every box of one initial image."""
    h, w = int(rgb.shape[0]), int(rgb.shape[1])
    boxes = np.asarray(boxes, dtype=np.float32).reshape(-1, 4)
    img = torch.from_numpy(np.ascontiguousarray(rgb)).permute(2, 0, 1).float()
    crops = np.zeros((len(boxes), 3, CROP, CROP), dtype=np.uint8)
    geometry = np.zeros((len(boxes), GEOMETRY), dtype=np.float32)
    for i, (x1, y1, x2, y2) in enumerate(boxes.tolist()):
        mx, my = (x2 - x1) * _MARGIN, (y2 - y1) * _MARGIN
        cx1, cy1 = max(0, int(np.floor(x1 - mx))), max(0, int(np.floor(y1 - my)))
        cx2, cy2 = min(w, int(np.ceil(x2 + mx))), min(h, int(np.ceil(y2 + my)))
        if cx2 - cx1 >= 1 and cy2 - cy1 >= 1:
            patch = img[:, cy1:cy2, cx1:cx2].unsqueeze(0)
            crop = F.interpolate(patch, size=(CROP, CROP), mode="bilinear", align_corners=False)
            crops[i] = crop[0].round().clamp(0, 255).to(torch.uint8).numpy()
        qx1, qx2 = int(x1 + 0.25 * (x2 - x1)), int(np.ceil(x2 - 0.25 * (x2 - x1)))
        qy1, qy2 = int(y1 + 0.25 * (y2 - y1)), int(np.ceil(y2 - 0.25 * (y2 - y1)))
        qx1, qy1 = min(max(qx1, 0), w - 1), min(max(qy1, 0), h - 1)
        qx2, qy2 = max(min(qx2, w), qx1 + 1), max(min(qy2, h), qy1 + 1)
        d = float(np.median(depth[qy1:qy2, qx1:qx2]))
        geometry[i] = ((x1 + x2) / 2 / w, (y1 + y2) / 2 / h, (x2 - x1) / w, (y2 - y1) / h, d)
    return ObjectInputs(crops, geometry, boxes, (w, h))


class CropEncoder(nn.Module):
    """Crops (B, 3, CROP, CROP) uint8 -> features (B, dim + 6)."""

    def __init__(self, dim: int = 64) -> None:
        super().__init__()
        self.net = nn.Sequential(
            nn.Conv2d(3, 16, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
            nn.Conv2d(16, 32, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
            nn.Conv2d(32, 64, 3, padding=1), nn.BatchNorm2d(64), nn.ReLU(), nn.MaxPool2d(2),
            nn.Conv2d(64, dim, 3, padding=1), nn.ReLU(),
            nn.AdaptiveAvgPool2d(1), nn.Flatten(),
        )
        self.out_dim = dim + 6

    def forward(self, crops: Tensor) -> Tensor:
        x = crops.float() / 255.0
        centre = x[:, :, CROP // 4 : 3 * CROP // 4, CROP // 4 : 3 * CROP // 4]
        stats = torch.cat([centre.mean(dim=(2, 3)), centre.std(dim=(2, 3))], dim=1)
        out: Tensor = torch.cat([self.net(x - 0.5), stats * 4.0], dim=1)
        return out
