"""Training pairs from a split part's renders: one sample per step and moved box.

Every stored episode holds the render of each state; ``EpisodeDataset`` (with
``step_images``) gives the initial one as an input and the later ones as targets. For step
``k`` the input is built from the render before it and the gold boxes before and after it
(:func:`~.inputs.step_inputs`), the target is the render after it. The network is fully
convolutional, so it trains on ``patch``-sized windows: one centred on each moved
object's old box and one on its new box (the windows hold all the pixels it paints).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from numpy.typing import NDArray
from torch import Tensor

from nsrmp_bench.dataset import EpisodeDataset
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.reconstruction.inputs import moved_objects, step_inputs

__all__ = ["Patches", "StepSample", "background_plate", "part_patches", "part_steps"]


@dataclass(frozen=True, eq=False)
class StepSample:
    """One step of a stored episode: images and gold boxes before and after it."""

    episode: str
    step: int  # 1-based
    before: NDArray[np.uint8]  # (H, W, 3)
    after: NDArray[np.uint8]
    boxes_before: NDArray[np.float64]  # (N, 4)
    boxes_after: NDArray[np.float64]


def part_steps(path: str | Path, limit: int = 0) -> Iterator[StepSample]:
    """The steps of the first ``limit`` episodes (0: all) of the data directory ``path``,
    read through ``EpisodeDataset`` (its targets: the renders after each step and the boxes)."""
    for item in EpisodeDataset(path, step_images=True).iter_items(limit):
        initial, after = item["inputs"]["rgb"], item["targets"]["rgb"]
        if initial is None or after is None:
            msg = (f"episode {item['id']} in {path} has no images; the reconstruction model "
                   "trains on renders: generate the split with rendering")
            raise InvalidArgument(msg)
        rgb = [initial.numpy(), *after.numpy()]
        boxes = item["targets"]["boxes"].numpy().astype(np.float64)
        for k in range(1, len(rgb)):
            yield StepSample(str(item["id"]), k, rgb[k - 1], rgb[k], boxes[k - 1], boxes[k])


def background_plate(path: str | Path, limit: int) -> NDArray[np.uint8]:
    """The empty scene ``(H, W, 3)``: the per-pixel median of the initial images of the
    first ``limit`` episodes of ``path`` (each pixel shows the table in most of them)."""
    images = []
    for item in EpisodeDataset(path).iter_items(max(1, limit)):
        if item["inputs"]["rgb"] is None:
            msg = f"episode {item['id']} in {path} has no images to make the plate from"
            raise InvalidArgument(msg)
        images.append(item["inputs"]["rgb"].numpy())
    if len({im.shape for im in images}) != 1:
        msg = f"{path} holds images of several sizes; the plate needs one camera"
        raise InvalidArgument(msg)
    out: NDArray[np.uint8] = np.median(np.stack(images), axis=0).round().astype(np.uint8)
    return out


@dataclass(frozen=True, eq=False)
class Patches:
    """Training windows: inputs ``(M, 8, P, P)`` and targets ``(M, 3, P, P)``, uint8."""

    inputs: Tensor
    targets: Tensor

    def __len__(self) -> int:
        return int(self.inputs.shape[0])


def _window(centre: float, size: int, limit: int) -> int:
    return int(np.clip(round(centre - size / 2), 0, limit - size))


def part_patches(path: str | Path, plate: NDArray[np.uint8], *, limit: int, patch: int,
                 margin: int) -> Patches:
    """Windows around every moved box of every step of the first ``limit`` episodes."""
    ins: list[NDArray[np.uint8]] = []
    outs: list[NDArray[np.uint8]] = []
    for s in part_steps(path, limit):
        moved = moved_objects(s.boxes_before, s.boxes_after)
        if len(moved) == 0:
            continue
        old, new = s.boxes_before[moved], s.boxes_after[moved]
        if s.before.shape != plate.shape:
            msg = (f"episode {s.episode} has {s.before.shape[1]}x{s.before.shape[0]} images, "
                   f"the plate {plate.shape[1]}x{plate.shape[0]}; use one camera")
            raise InvalidArgument(msg)
        x = step_inputs(s.before, old, new, plate, margin=margin)
        y = s.after.transpose(2, 0, 1)
        h, w = s.before.shape[:2]
        if h < patch or w < patch:
            msg = f"patch {patch} is larger than the {w}x{h} images; pass a smaller patch"
            raise InvalidArgument(msg)
        for box in np.concatenate([old, new]):
            x0 = _window((box[0] + box[2]) / 2, patch, w)
            y0 = _window((box[1] + box[3]) / 2, patch, h)
            ins.append(x[:, y0:y0 + patch, x0:x0 + patch].copy())  # not a view of x
            outs.append(y[:, y0:y0 + patch, x0:x0 + patch].copy())
    if not ins:
        msg = f"{path} holds no step that moves an object; nothing to train on"
        raise InvalidArgument(msg)
    return Patches(torch.from_numpy(np.stack(ins)), torch.from_numpy(np.stack(outs)))
