"""Initial scenes as tensors the detector trains on and reads, from ``EpisodeDataset`` items.

Per episode: the initial RGB, the height above the table (from depth and the episode's
camera, :func:`nsrmp_bench.detection.height.height_map`), and for training the gold
initial amodal boxes with each object's shape and colour index (the item's ``targets``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor

from nsrmp_bench.dataset import item_camera
from nsrmp_bench.detection.height import height_map
from nsrmp_bench.errors import InvalidArgument

__all__ = ["Scenes", "read_scenes"]


@dataclass
class Scenes:
    """E initial scenes of one image size."""

    ids: list[str]
    rgb: Tensor  # (E, H, W, 3) uint8
    height: Tensor  # (E, H, W) float16 metres above the table
    boxes: list[Tensor]  # per episode (N, 4) float32 pixel xyxy (training only)
    shapes: list[Tensor]  # per episode (N,) int64 index into SHAPES
    colours: list[Tensor]  # per episode (N,) int64 index into COLOURS

    def __len__(self) -> int:
        return len(self.ids)


def read_scenes(items: Iterable[Mapping[str, Any]], *, targets: bool) -> Scenes:
    """The initial scenes of ``items`` (dataset items, read one at a time).

    Reads ``inputs`` only unless ``targets`` (training): then also the gold initial boxes
    (the inputs' boxes) and each object's shape and colour (``targets``); without it
    ``boxes``, ``shapes`` and ``colours`` stay empty.
    """
    ids: list[str] = []
    rgb: list[Tensor] = []
    height: list[Tensor] = []
    boxes, shapes, colours = [], [], []
    for item in items:
        inp = item["inputs"]
        eid = str(item["id"])
        if inp["rgb"] is None or inp["depth"] is None:
            msg = (f"episode {eid!r} has no initial image: a detector reads it; generate the "
                   "split with rendering (and images)")
            raise InvalidArgument(msg)
        if rgb and tuple(inp["rgb"].shape) != tuple(rgb[0].shape):
            msg = (f"episode {eid!r} has a {tuple(inp['rgb'].shape)} image, episode "
                   f"{ids[0]!r} a {tuple(rgb[0].shape)} one; a detector reads one image size "
                   "at a time: detect each split part on its own")
            raise InvalidArgument(msg)
        ids.append(eid)
        rgb.append(inp["rgb"])
        depth = np.asarray(inp["depth"].numpy())
        height.append(torch.from_numpy(height_map(depth, item_camera(item)).astype(np.float16)))
        if targets:
            tg = item["targets"]
            boxes.append(inp["boxes"].to(torch.float32))
            shapes.append(tg["shapes"])
            colours.append(tg["colours"])
    if not ids:
        msg = "no episodes to read: pass a split part with rendered episodes"
        raise InvalidArgument(msg)
    return Scenes(ids, torch.stack(rgb), torch.stack(height), boxes, shapes, colours)
