"""The learned detector (``detector-v1``): a small CenterNet trained from scratch on the
train renders (RGB and height above the table), run on the CPU.

``nsrmp-bench train detector --data data/paper-v2 --out runs/detector`` trains it through
the shared loop (:mod:`nsrmp_bench.reference_model.training`); ``nsrmp-bench detect``
writes its detections. See ``MODEL_CARD.md`` beside this file.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any, ClassVar

import torch
from torch import Tensor

from nsrmp_bench.dataset import EpisodeDataset
from nsrmp_bench.detection.detections import Detections
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.base import LearnedModel, TrainingPlan
from nsrmp_bench.reference_model.contract import Kind, ModelConfig
from nsrmp_bench.reference_model.detector.config import DetectorConfig
from nsrmp_bench.reference_model.detector.loss import detection_loss
from nsrmp_bench.reference_model.detector.model import CenterNet, decode, image_tensor
from nsrmp_bench.reference_model.detector.scenes import Scenes, read_scenes
from nsrmp_bench.reference_model.training import Stage
from nsrmp_bench.scoring.matching import MATCH_IOU, hungarian_match
from nsrmp_bench.vocabulary import COLOURS, SHAPES

__all__ = ["MODEL_ID", "DetectorConfig", "DetectorPredictor", "detect_scenes",
           "detect_with"]

MODEL_ID = "detector-v1"
_CHUNK = 200  # episodes read into memory at a time when detecting a part


def _crop_batch(scenes: Scenes, rows: Tensor, cfg: DetectorConfig
                ) -> tuple[Tensor, list[Tensor], list[Tensor], list[Tensor]]:
    """Random training crops (global torch RNG, seeded per epoch by the loop)."""
    _, h, w, _ = scenes.rgb.shape
    ch, cw = min(cfg.crop_height, h), min(cfg.crop_width, w)
    xs, boxes = [], []
    for r in rows.tolist():
        y0 = int(torch.randint(0, h - ch + 1, ()).item()) // 4 * 4
        x0 = int(torch.randint(0, w - cw + 1, ()).item()) // 4 * 4
        xs.append(image_tensor(scenes.rgb[r:r + 1, y0:y0 + ch, x0:x0 + cw],
                               scenes.height[r:r + 1, y0:y0 + ch, x0:x0 + cw]))
        boxes.append(scenes.boxes[r] - torch.tensor([x0, y0, x0, y0], dtype=torch.float32))
    rl = rows.tolist()
    return (torch.cat(xs), boxes, [scenes.shapes[r] for r in rl],
            [scenes.colours[r] for r in rl])


def detect_scenes(model: CenterNet, scenes: Scenes, cfg: DetectorConfig,
                  batch: int = 16) -> list[Detections]:
    """The detections of every scene (whole images, eval mode, no grad)."""
    model.eval()
    out: list[Detections] = []
    w, h = scenes.rgb.shape[2], scenes.rgb.shape[1]
    limit = torch.tensor([w, h, w, h], dtype=torch.float32)
    with torch.no_grad():
        for s in range(0, len(scenes), batch):
            x = image_tensor(scenes.rgb[s:s + batch], scenes.height[s:s + batch])
            for i, d in enumerate(decode(model(x), cfg.score_threshold, cfg.max_detections)):
                boxes = torch.minimum(d.boxes.clamp(min=0.0), limit)
                out.append(Detections(
                    scenes.ids[s + i], boxes.double().numpy(), d.scores.double().numpy(),
                    tuple(SHAPES[j] for j in d.shapes.tolist()),
                    tuple(COLOURS[j] for j in d.colours.tolist())))
    return out


def _val_f1(model: CenterNet, val: Scenes, cfg: DetectorConfig) -> float:
    """F1 of detections matched to gold objects at IoU >= 0.5 (the in-loop selection)."""
    dets = detect_scenes(model, val, cfg)
    tp = n_gold = n_det = 0
    for d, gold in zip(dets, val.boxes, strict=True):
        m = hungarian_match(gold.numpy(), d.boxes, MATCH_IOU)
        tp += int((m >= 0).sum())
        n_gold += len(gold)
        n_det += len(d)
    return 2 * tp / max(1, n_gold + n_det)


class DetectorPredictor(LearnedModel):
    """``detector-v1``: trains on ``data/train``, selects on the first episodes of
    ``data/val`` (F1 at IoU 0.5); writes detections, not predictions (:meth:`detect_part`,
    ``nsrmp-bench detect``)."""

    model_id = MODEL_ID
    kind = Kind.DETECTOR
    config_cls: ClassVar[type[ModelConfig]] = DetectorConfig
    supervision = "gold initial amodal boxes, each object's shape and colour"
    inputs = "initial RGB, initial depth (as height above the table via the camera)"
    tiny_overrides: ClassVar[dict[str, object]] = {
        "epochs": 3, "batch_size": 4, "width": 8, "train_limit": 0, "val_limit": 4}
    config: DetectorConfig
    model: CenterNet

    @classmethod
    def build_network(cls, config: DetectorConfig, vocab_size: int,
                      state: Mapping[str, Tensor]) -> CenterNet:
        return CenterNet(config.width)

    @classmethod
    def check_data(cls, data: Path, config: DetectorConfig) -> None:
        super().check_data(data, config)
        if not (data / "val" / "manifest.json").exists():
            msg = f"{data} has no val part ({data / 'val'}); the detector selects on it"
            raise InvalidArgument(msg)

    @classmethod
    def plan_training(cls, data: Path, config: DetectorConfig, seed: int) -> TrainingPlan:
        cfg = config
        t0 = time.perf_counter()
        train = read_scenes(EpisodeDataset(data / "train").iter_items(cfg.train_limit),
                            targets=True)
        val = read_scenes(EpisodeDataset(data / "val").iter_items(cfg.val_limit), targets=True)
        read_seconds = time.perf_counter() - t0
        model = CenterNet(cfg.width)

        def step(rows: Tensor) -> Tensor:
            x, boxes, shapes, colours = _crop_batch(train, rows, cfg)
            return detection_loss(model(x), boxes, shapes, colours)

        stage = Stage("detector", cfg.epochs, torch.arange(len(train)),
                      lambda: list(model.parameters()), step, cfg.lr, cfg.batch_size,
                      uses_splitter=True)
        return TrainingPlan(
            network=model, stages=[stage], validate=lambda _s: _val_f1(model, val, cfg),
            training_data=(f"{len(train)} initial scenes of {data / 'train'}; selection on "
                           f"the first {len(val)} of val (F1 at IoU 0.5)"),
            score_name="val F1", read_seconds=read_seconds)

    def detect(self, items: Iterable[Mapping[str, Any]]) -> list[Detections]:
        """Detections of the initial scene of every dataset item (reads ``inputs`` only)."""
        self.set_threads()
        return detect_scenes(self.model, read_scenes(items, targets=False), self.config)

    def detect_part(self, data: str | Path) -> Iterator[Detections]:
        """Detections of every episode of a part, read through ``EpisodeDataset`` in chunks."""
        ds = EpisodeDataset(data)
        for start in range(0, len(ds), _CHUNK):
            yield from self.detect(ds.iter_items(_CHUNK, start=start))


def detect_with(part: Path, checkpoint: Path | None
                ) -> tuple[str, Iterator[Detections], dict[str, object]]:
    """The learned detector (``checkpoint``, else the shipped one) over a part, as
    :func:`nsrmp_bench.detection.part_detection.detect_part` runs it."""
    from nsrmp_bench.reference_model.checkpoints import shipped_checkpoint

    path = checkpoint if checkpoint is not None else shipped_checkpoint(MODEL_ID)
    model = DetectorPredictor.from_checkpoint(path)
    return MODEL_ID, model.detect_part(part), {"checkpoint": path.name}
