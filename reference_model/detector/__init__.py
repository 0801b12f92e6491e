"""The learned detector (``detector-v1``): a small CenterNet trained from scratch on the
train renders (RGB and height above the table), run on the CPU.

``nsrmp-bench train detector --data data/paper-v2 --out runs/detector`` trains it through
the shared loop (:mod:`nsrmp_bench.reference_model.training`); ``nsrmp-bench detect``
writes its detections. See ``MODEL_CARD.md`` beside this file.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import torch
from torch import Tensor

from nsrmp_bench.detection.detections import Detections
from nsrmp_bench.detection.matching import MATCH_IOU, hungarian_match
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.checkpoints import load_checkpoint, save_checkpoint, write_card
from nsrmp_bench.reference_model.detector.config import DetectorConfig
from nsrmp_bench.reference_model.detector.loss import detection_loss
from nsrmp_bench.reference_model.detector.model import CenterNet, decode, image_tensor
from nsrmp_bench.reference_model.detector.scenes import Scenes, read_scenes
from nsrmp_bench.reference_model.training import Stage, train_stages
from nsrmp_bench.vocabulary import COLOURS, SHAPES

__all__ = ["MODEL_ID", "DetectorConfig", "DetectorPredictor", "train_detector"]

MODEL_ID = "detector-v1"


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


def train_detector(data: Path, out: Path, *, seed: int = 0,
                   config: DetectorConfig | None = None, quiet: bool = False) -> Path:
    """Train on ``data/train``, select on the first episodes of ``data/val``; returns
    ``out/best.pt``."""
    cfg = config or DetectorConfig()
    if not (data / "train" / "manifest.json").exists():
        msg = (f"{data} has no finished part 'train' ({data / 'train'}); pass a split root "
               "holding train/ (and val/), e.g. data/paper-v2")
        raise InvalidArgument(msg)
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(seed)
    t0 = time.perf_counter()
    train = read_scenes(data / "train", targets=True, limit=cfg.train_limit)
    if (data / "val" / "manifest.json").exists():
        val = read_scenes(data / "val", targets=True, limit=cfg.val_limit)
    else:
        msg = f"{data} has no val part ({data / 'val'}); the detector selects on it"
        raise InvalidArgument(msg)
    load_seconds = time.perf_counter() - t0
    model = CenterNet(cfg.width)
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.json").write_text(json.dumps(cfg.to_dict(), indent=1) + "\n", "utf-8")
    best = out / "best.pt"

    def step(rows: Tensor) -> Tensor:
        x, boxes, shapes, colours = _crop_batch(train, rows, cfg)
        return detection_loss(model(x), boxes, shapes, colours)

    def on_best() -> None:
        save_checkpoint(best, MODEL_ID, cfg.to_dict(), [], model.state_dict(),
                        {"seed": seed, "data": str(data)})

    stage = Stage("detector", cfg.epochs, torch.arange(len(train)),
                  lambda: list(model.parameters()), step, cfg.lr, cfg.batch_size,
                  uses_splitter=True)
    state = train_stages(model, [stage], out, seed=seed,
                         validate=lambda _s: _val_f1(model, val, cfg), on_best=on_best,
                         quiet=quiet)
    n_params = sum(p.numel() for p in model.parameters())
    write_card(out / "card.json", {
        "model": MODEL_ID,
        "training_data": f"{len(train)} initial scenes of {data / 'train'}; selection on "
                         f"the first {len(val)} of val (F1 at IoU 0.5)",
        "train_seconds": round(state.seconds, 1), "load_seconds": round(load_seconds, 1),
        "wall_seconds": round(time.perf_counter() - t0, 1), "parameters": n_params,
        "best_val_f1": round(state.best, 4), "seed": seed, "threads": cfg.threads,
        "supervision": "gold initial amodal boxes, each object's shape and colour",
        "inputs": "initial RGB, initial depth (as height above the table via the camera)",
        "config": cfg.to_dict(),
    })
    return best


class DetectorPredictor:
    """A loaded learned detector."""

    model_id = MODEL_ID

    def __init__(self, checkpoint: str | Path) -> None:
        payload = load_checkpoint(checkpoint, MODEL_ID)
        self.config = DetectorConfig.from_dict(payload["config"])
        self.model = CenterNet(self.config.width)
        self.model.load_state_dict(payload["state"])
        self.model.eval()
        self.checkpoint = Path(checkpoint)

    def detect(self, scenes: Scenes) -> list[Detections]:
        """Detections of every scene."""
        torch.set_num_threads(self.config.threads)
        return detect_scenes(self.model, scenes, self.config)

    def detect_part(self, data: str | Path) -> Iterator[Detections]:
        """Detections of every episode of a part, read in chunks."""
        from nsrmp_bench.storage.reader import open as open_collection

        col = open_collection(data)
        for s in range(0, len(col), 200):
            yield from self.detect(read_scenes(col, targets=False, start=s, stop=s + 200))

    def predict(self, items: Any, camera: Any) -> Any:
        """The detector writes detections, not predictions (``nsrmp-bench detect``)."""
        msg = ("detector-v1 writes detections, not a predictions file: run `nsrmp-bench "
               "detect --detector learned --data DATA --out detections.jsonl`")
        raise InvalidArgument(msg)
