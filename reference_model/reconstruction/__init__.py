"""Scene reconstruction (``reconstruction-v1``): images of the predicted sub-goal states.

A small U-Net, trained from scratch on the per-step renders, turns the image before a step
and the moved objects' boxes before and after it into the image after the step; a plan's
steps chain its own outputs. No simulator at inference. See ``MODEL_CARD.md`` beside this
file; :mod:`.reconstruct` runs it (or PyBullet, the reference row) over a predictions file
and scores it with SSIM.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import torch
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.base import LearnedModel, TrainingPlan
from nsrmp_bench.reference_model.contract import Kind, ModelConfig
from nsrmp_bench.reference_model.reconstruction.config import ReconstructionConfig
from nsrmp_bench.reference_model.reconstruction.data import (
    Patches,
    background_plate,
    part_patches,
)
from nsrmp_bench.reference_model.reconstruction.inputs import (
    INPUT_CHANNELS,
    moved_objects,
    step_inputs,
)
from nsrmp_bench.reference_model.reconstruction.model import ReconstructionNet
from nsrmp_bench.reference_model.training import Stage

__all__ = ["MODEL_ID", "ReconstructionConfig", "ReconstructionPredictor",
           "val_region_ssim"]

MODEL_ID = "reconstruction-v1"


def _region_l1(model: ReconstructionNet, patches: Patches, rows: torch.Tensor) -> torch.Tensor:
    x = patches.inputs[rows]
    target = patches.targets[rows].float() / 255.0
    region = torch.maximum(x[:, 9:10], x[:, 10:11]).float() / 255.0
    err = (model(x) - target).abs() * region
    loss: torch.Tensor = err.sum() / (3.0 * region.sum()).clamp_min(1.0)
    return loss


def val_region_ssim(model: ReconstructionNet, patches: Patches) -> float:
    """Mean SSIM inside the moved boxes of the validation windows, for model selection.

    The figures we report come from ``nsrmp-bench reconstruct`` on whole images; this is the
    cheap in-loop number the best checkpoint is chosen by.
    """
    from nsrmp_bench.reference_model.reconstruction.ssim import ssim_scores

    was = model.training
    model.eval()
    scores = []
    with torch.no_grad():
        for lo in range(0, len(patches), 256):
            x = patches.inputs[lo:lo + 256]
            pred = (model(x) * 255.0).round().to(torch.uint8).permute(0, 2, 3, 1).numpy()
            gold = patches.targets[lo:lo + 256].permute(0, 2, 3, 1).numpy()
            region = ((x[:, 9] > 0) | (x[:, 10] > 0)).numpy()
            for p, g, r in zip(pred, gold, region, strict=True):
                scores.append(ssim_scores(p, g, r)[1])
    model.train(was)
    return float(np.nanmean(scores))


class ReconstructionPredictor(LearnedModel):
    """``reconstruction-v1``: trains on the renders of ``data/train``, selects on
    ``data/val`` (a split without a val part selects on the last tenth of the train
    episodes read); makes the image after a step from the image before it (:meth:`step`,
    :meth:`chain`; :meth:`reconstruct` from a dataset item; ``nsrmp-bench reconstruct`` runs
    it over a predictions file)."""

    model_id = MODEL_ID
    kind = Kind.RECONSTRUCTION
    config_cls: ClassVar[type[ModelConfig]] = ReconstructionConfig
    supervision = ("the render after each step (target), the renders and gold amodal "
                   "boxes before and after it (inputs at training time)")
    inputs = ("image before the step; boxes of the objects the step moved, before and "
              "after it (rasterised masks, and the non-learned paste composite); the "
              "plate (median of training images, stored in the checkpoint)")
    tiny_overrides: ClassVar[dict[str, object]] = {
        "channels": 8, "patch": 32, "epochs": 3, "batch_size": 16, "train_episodes": 0,
        "val_episodes": 0, "plate_episodes": 16}
    config: ReconstructionConfig
    model: ReconstructionNet

    @classmethod
    def build_network(cls, config: ReconstructionConfig, vocab_size: int,
                      state: Mapping[str, torch.Tensor]) -> ReconstructionNet:
        plate = state["plate"]
        return ReconstructionNet(config.channels, INPUT_CHANNELS,
                                 (int(plate.shape[0]), int(plate.shape[1])))

    @classmethod
    def plan_training(cls, data: Path, config: ReconstructionConfig,
                      seed: int) -> TrainingPlan:
        cfg = config
        t0 = time.perf_counter()
        plate = background_plate(data / "train", cfg.plate_episodes)
        opts = {"patch": cfg.patch, "margin": cfg.margin}
        train = part_patches(data / "train", plate, limit=cfg.train_episodes, **opts)
        if (data / "val" / "manifest.json").exists():
            val = part_patches(data / "val", plate, limit=cfg.val_episodes, **opts)
        else:
            cut = len(train) - max(1, len(train) // 10)
            train, val = (Patches(train.inputs[:cut], train.targets[:cut]),
                          Patches(train.inputs[cut:], train.targets[cut:]))
        read_seconds = time.perf_counter() - t0
        model = ReconstructionNet(cfg.channels, INPUT_CHANNELS, plate.shape[:2],
                                  cfg.head_init_std)
        model.plate.copy_(torch.from_numpy(plate))
        stage = Stage("reconstruct", cfg.epochs, torch.arange(len(train)),
                      lambda: list(model.parameters()),
                      lambda rows: _region_l1(model, train, rows), cfg.lr, cfg.batch_size,
                      uses_splitter=True)  # every epoch runs the model as it is used
        return TrainingPlan(
            network=model, stages=[stage],
            validate=lambda _stage: val_region_ssim(model, val),
            training_data=(f"{len(train)} windows ({cfg.patch}x{cfg.patch}) around the "
                           "moved boxes of every step of the first "
                           f"{cfg.train_episodes or 'all'} episodes of {data / 'train'}; "
                           f"selection on {len(val)} windows of val"),
            score_name="val region SSIM", read_seconds=read_seconds)

    def step(self, before: NDArray[np.uint8], boxes_before: NDArray[Any],
             boxes_after: NDArray[Any]) -> NDArray[np.uint8]:
        """The image ``(H, W, 3)`` after a step that takes the boxes ``(N, 4)`` from
        ``boxes_before`` to ``boxes_after`` (objects whose box did not change stay)."""
        plate = self.model.plate.numpy()
        if before.shape != plate.shape:
            msg = (f"the image is {before.shape[1]}x{before.shape[0]} but {self.checkpoint.name} "
                   f"was trained on {plate.shape[1]}x{plate.shape[0]} images of one camera; "
                   "train a checkpoint on data of this camera")
            raise InvalidArgument(msg)
        moved = moved_objects(boxes_before, boxes_after)
        if len(moved) == 0:
            return before.copy()
        x = step_inputs(before, np.asarray(boxes_before)[moved],
                        np.asarray(boxes_after)[moved], plate, margin=self.config.margin)
        h, w = before.shape[:2]
        ph, pw = -h % 4, -w % 4  # pad to multiples of 4 (edge pixels), crop back
        t = torch.from_numpy(np.pad(x, ((0, 0), (0, ph), (0, pw)), mode="edge"))[None]
        self.set_threads()
        with torch.no_grad():
            y = self.model(t)[0, :, :h, :w]
        out: NDArray[np.uint8] = (y * 255.0).round().to(torch.uint8).permute(1, 2, 0).numpy()
        return np.ascontiguousarray(out)

    def reconstruct(self, item: Mapping[str, Any], step_boxes: NDArray[Any]
                    ) -> list[NDArray[np.uint8]]:
        """The images after each of the steps ``step_boxes`` ``(S, N, 4)`` of a dataset item,
        from its initial image and boxes (reads ``inputs`` only; see :meth:`chain`)."""
        inp = item["inputs"]
        if inp["rgb"] is None or inp["boxes"] is None:
            msg = (f"episode {item['id']!r} has no initial image or boxes; the reconstruction "
                   "network starts from them: generate the split with rendering")
            raise InvalidArgument(msg)
        return self.chain(inp["rgb"].numpy(), inp["boxes"].numpy(), step_boxes)

    def chain(self, initial: NDArray[np.uint8], initial_boxes: NDArray[Any],
              step_boxes: NDArray[Any]) -> list[NDArray[np.uint8]]:
        """The images after each of the steps ``step_boxes`` ``(S, N, 4)``, each step read
        from the previous step's reconstruction."""
        images = []
        image, boxes = initial, np.asarray(initial_boxes, np.float64)
        for nxt in np.asarray(step_boxes, np.float64):
            image = self.step(image, boxes, nxt)
            images.append(image)
            boxes = nxt
        return images
