"""The dense baseline (not CLIPort): a from-scratch, Transporter-style FCN that reads the
initial RGB-D and the instruction and predicts a pick heatmap and, by a transport, a place
heatmap.

Two registered ids share this module: ``dense-v2`` (trained on the single-step episodes
of paper-v2/train; the network is :mod:`.transport`) and ``dense5x-v2`` (``dense-v2`` on
dense5x-v2/train, five times as many, for the same epochs, selected on paper-v2/val). The
retired ``dense-v1`` and ``dense5x-v1`` (the same pick stream, a second stream for the
place) were last released in nsrmp-bench 0.2.0. See ``MODEL_CARD.md`` beside this file.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar

import torch
import torch.nn.functional as F
from torch import Tensor

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.base import PredictionModel, TrainingPlan
from nsrmp_bench.reference_model.contract import Kind, ModelConfig
from nsrmp_bench.reference_model.dense.config import Dense5xV2Config, DenseV2Config
from nsrmp_bench.reference_model.dense.inference import Inferred, infer
from nsrmp_bench.reference_model.dense.inputs import DenseInputs, encode_items, encode_part
from nsrmp_bench.reference_model.dense.transport import TransportNet
from nsrmp_bench.reference_model.training import Stage
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["MODEL_ID_5X_V2", "MODEL_ID_V2", "Dense5xV2Config", "Dense5xV2Predictor",
           "DenseV2Config", "DenseV2Predictor", "val_accuracy"]

MODEL_ID_V2 = "dense-v2"
MODEL_ID_5X_V2 = "dense5x-v2"
LABEL = "not CLIPort"


def val_accuracy(model: TransportNet, enc: DenseInputs) -> tuple[float, float]:
    """(identification, placement) on encoded single-step episodes with targets: the
    picked object is the moved one; the place lies in its box after the step.

    The figures we report come from the public scorer; this is the in-loop number the
    best checkpoint is chosen by (their mean)."""
    assert enc.subject is not None and enc.place_box is not None
    res = infer(model, enc)
    ident = torch.tensor(res.subjects) == enc.subject
    box, p = enc.place_box.numpy(), res.places
    inside = ((box[:, 0] <= p[:, 0]) & (p[:, 0] <= box[:, 2])
              & (box[:, 1] <= p[:, 1]) & (p[:, 1] <= box[:, 3]))
    return float(ident.float().mean()), float(inside.mean())


def shifted(image: Tensor, pick: Tensor, place: Tensor, grid: tuple[int, int],
            shift: int) -> tuple[Tensor, Tensor, Tensor]:
    """Augmentation: the batch's images translated by a random whole number of heatmap
    cells (at most ``shift`` each way; zeros come in) and the target cells with them;
    rows whose pick or place would leave the grid keep their own image."""
    h, w = grid
    dy, dx = (int(v) for v in torch.randint(-shift, shift + 1, (2,)))
    py, px, qy, qx = pick // w + dy, pick % w + dx, place // w + dy, place % w + dx
    ok = (py >= 0) & (py < h) & (px >= 0) & (px < w) & (qy >= 0) & (qy < h) & (qx >= 0) & (qx < w)
    moved = torch.roll(image, (2 * dy, 2 * dx), dims=(2, 3))
    if dy > 0:
        moved[:, :, : 2 * dy] = 0
    elif dy < 0:
        moved[:, :, 2 * dy:] = 0
    if dx > 0:
        moved[:, :, :, : 2 * dx] = 0
    elif dx < 0:
        moved[:, :, :, 2 * dx:] = 0
    keep = ok[:, None, None, None]
    return (torch.where(keep, moved, image), torch.where(ok, py * w + px, pick),
            torch.where(ok, qy * w + qx, place))


def _loss(model: TransportNet, enc: DenseInputs, rows: Tensor, shift: int = 0) -> Tensor:
    assert enc.pick is not None and enc.place is not None
    image, pick, place = enc.image(rows), enc.pick[rows], enc.place[rows]
    if shift:
        image, pick, place = shifted(image, pick, place, enc.grid, shift)
    x = model.image_input(image)
    text = model.text(enc.tokens_of(rows))
    return (F.cross_entropy(model.pick_logits(x, text), pick)
            + F.cross_entropy(model.place_logits(x, text, pick), place))


class DenseV2Predictor(PredictionModel):
    """``dense-v2``: trains on the single-step episodes of ``data/train``, selects on those
    of ``data/val``; predicts from what ``EpisodeDataset`` gives as ``inputs``, the place
    by a Transporter transport (:class:`.transport.TransportNet`).

    A single-step model: on a multi-step episode it predicts one pick and place for the
    whole instruction (one object moved, the others where they were)."""

    model_id = MODEL_ID_V2
    kind = Kind.DENSE
    label = LABEL
    config_cls: ClassVar[type[ModelConfig]] = DenseV2Config
    supervision = ("the moved object's initial and final box centres (pick and place "
                   "pixels) of single-step episodes; nothing else")
    inputs = ("instruction text, initial RGB, initial depth (pooled by scale); the "
              "initial (gold) boxes only to snap the pick to an object and to move its box")
    data_hint = "e.g. data/paper-v2"
    tiny_overrides: ClassVar[dict[str, object]] = {
        "epochs": 3, "batch_size": 4, "width": 8, "word_dim": 16, "text_hidden": 16,
        "val": "val", "val_limit": 8, "read_workers": 1, "decay_epochs": 1, "key_dim": 4,
        "crop": 3}
    config: DenseV2Config
    model: TransportNet

    @classmethod
    def build_network(cls, config: DenseV2Config, vocab_size: int,
                      state: Mapping[str, Tensor]) -> TransportNet:
        return TransportNet(vocab_size, config)

    @classmethod
    def check_data(cls, data: Path, config: DenseV2Config) -> None:
        super().check_data(data, config)
        val_dir = (data / config.val).resolve()
        if not (val_dir / "manifest.json").exists():
            msg = (f"the validation part {val_dir} (--data {data} + val {config.val!r}) is "
                   "not a finished part; pass --set val=PATH relative to --data (dense5x-v2 "
                   "has no val: it selects on ../paper-v2/val beside it)")
            raise InvalidArgument(msg)

    @classmethod
    def plan_training(cls, data: Path, config: DenseV2Config, seed: int) -> TrainingPlan:
        cfg = config
        train_dir, val_dir = data / "train", (data / cfg.val).resolve()
        t0 = time.perf_counter()
        train, vocab = encode_part(train_dir, None, cfg.scale, single_step=True, targets=True,
                                   workers=cfg.read_workers)
        val, _ = encode_part(val_dir, vocab, cfg.scale, single_step=True, targets=True,
                             limit=cfg.val_limit)
        read_seconds = time.perf_counter() - t0
        model = cls.build_network(cfg, len(vocab), {})
        last: dict[str, float] = {}

        def validate(stage: Stage) -> float:
            ident, place = val_accuracy(model, val)
            last.update(identification=ident, placement=place)
            return (ident + place) / 2

        return TrainingPlan(
            network=model, stages=cls.stages(cfg, model, train), validate=validate,
            training_data=(f"{len(train)} single-step episodes of {train_dir}; selection on "
                           f"the first {len(val)} single-step episodes of {val_dir.name} "
                           f"({val_dir.parent.name})"),
            vocab=vocab.to_list(), score_name="val_id_pl", read_seconds=read_seconds,
            checkpoint_extra=lambda: {"val": {k: round(v, 4) for k, v in last.items()}})

    @classmethod
    def stages(cls, cfg: DenseV2Config, model: TransportNet, train: DenseInputs) -> list[Stage]:
        """``cfg.epochs`` in all: the last ``decay_epochs`` of them a second stage at
        ``lr * decay`` (a fresh Adam), both selecting on validation."""
        rows = torch.arange(len(train))

        def stage(name: str, epochs: int, lr: float) -> Stage:
            return Stage(name, epochs, rows, lambda: list(model.parameters()),
                         lambda r: _loss(model, train, r, cfg.shift), lr, cfg.batch_size,
                         uses_splitter=True)

        first = cfg.epochs - cfg.decay_epochs
        out = [stage("dense", first, cfg.lr)] if first > 0 else []
        if cfg.decay_epochs:
            out.append(stage("dense-decay", cfg.decay_epochs, cfg.lr * cfg.decay))
        return out

    def infer(self, items: Sequence[dict[str, Any]]) -> tuple[DenseInputs, Inferred]:
        """Encode the items' inputs and run the model."""
        self.set_threads()
        enc, _ = encode_items(items, self.vocab, self.config.scale, targets=False)
        return enc, infer(self.model, enc)

    def predict(self, items: Sequence[dict[str, Any]]) -> Iterator[Prediction]:
        """Predictions (boxes, pick, place) for dataset items (``{"id", "inputs"}``).

        The camera is not read: pick and place are pixels, as the boxes are."""
        enc, res = self.infer(items)
        for i, eid in enumerate(enc.ids):
            yield Prediction(id=eid, boxes=res.boxes[i],
                             pick=(float(res.picks[i, 0]), float(res.picks[i, 1])),
                             place=(float(res.places[i, 0]), float(res.places[i, 1])))


class Dense5xV2Predictor(DenseV2Predictor):
    """``dense5x-v2``: ``dense-v2`` on ``data/train`` (dense5x-v2, five times the
    episodes) for the same epochs, selecting on ``data/../paper-v2/val``."""

    model_id = MODEL_ID_5X_V2
    label = "not CLIPort, 5x data"
    config_cls = Dense5xV2Config
    data_hint = "e.g. data/dense5x-v2 (with data/paper-v2 beside it for validation)"
