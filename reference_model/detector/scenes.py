"""A split part's initial scenes as tensors the detector trains on and reads.

Per episode: the initial RGB, the height above the table (from depth and the camera,
:func:`nsrmp_bench.detection.height.height_map`), and for training the gold initial
amodal boxes with each object's shape and colour index (the scene's objects).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import Tensor

from nsrmp_bench.detection.height import height_map
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.reader import EpisodeCollection
from nsrmp_bench.storage.reader import open as open_collection
from nsrmp_bench.vocabulary import COLOURS, SHAPES

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


def read_scenes(source: str | Path | EpisodeCollection, *, targets: bool,
                limit: int = 0, start: int = 0, stop: int | None = None) -> Scenes:
    """The initial scenes of a part: positions ``start`` to ``stop`` (exclusive; default
    the end), or the first ``limit`` episodes if ``limit`` > 0.

    Without ``targets`` only inputs are read (``boxes``, ``shapes``, ``colours`` empty).
    """
    col = source if isinstance(source, EpisodeCollection) else open_collection(source)
    end = len(col) if limit <= 0 else min(limit, len(col))
    end = end if stop is None else min(stop, end)
    positions = range(start, end)
    n = len(positions)
    if n == 0:
        msg = f"{source} holds no episodes; pass a split part with rendered episodes"
        raise InvalidArgument(msg)
    first = col.episode(0, images=False).rendering
    if first is None:
        msg = (f"{source} holds symbolic episodes without rendering; a detector reads the "
               "initial image: generate the split with rendering")
        raise InvalidArgument(msg)
    camera = first.camera
    ids: list[str] = []
    rgb = torch.zeros((n, camera.height, camera.width, 3), dtype=torch.uint8)
    height = torch.zeros((n, camera.height, camera.width), dtype=torch.float16)
    boxes, shapes, colours = [], [], []
    shape_ix = {s: i for i, s in enumerate(SHAPES)}
    colour_ix = {c: i for i, c in enumerate(COLOURS)}
    for i, pos in enumerate(positions):
        if targets:
            inp, tg = col.read_item(pos, arrays=())
        else:
            inp = col.read_inputs(pos)
        if inp["rgb"] is None:
            msg = f"episode {inp['id']!r} of {source} has no rendering; a detector reads it"
            raise InvalidArgument(msg)
        ids.append(str(inp["id"]))
        rgb[i] = torch.from_numpy(np.ascontiguousarray(inp["rgb"]))
        height[i] = torch.from_numpy(height_map(inp["depth"], camera).astype(np.float16))
        if targets:
            objs = tg["symbolic"]["scene"]["objects"]
            boxes.append(torch.from_numpy(np.asarray(inp["boxes"], dtype=np.float32)))
            shapes.append(torch.tensor([shape_ix[o["shape"]] for o in objs]))
            colours.append(torch.tensor([colour_ix[o["colour"]] for o in objs]))
    col.close()
    return Scenes(ids, rgb, height, boxes, shapes, colours)
