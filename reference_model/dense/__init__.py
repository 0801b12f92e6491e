"""The dense baseline (not CLIPort): a from-scratch, Transporter-style two-stream FCN that
reads the initial RGB-D and the instruction and predicts a pick and a place heatmap.

Two registered ids share this module: ``dense-v1`` (trained on the single-step episodes
of paper-v2/train) and ``dense5x-v1`` (on dense5x-v2/train, five times as many, selected
on paper-v2/val). See ``MODEL_CARD.md`` beside this file.
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
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.reference_model.base import PredictionModel, TrainingPlan
from nsrmp_bench.reference_model.contract import Kind, ModelConfig
from nsrmp_bench.reference_model.dense.config import Dense5xConfig, DenseConfig
from nsrmp_bench.reference_model.dense.inference import Inferred, infer
from nsrmp_bench.reference_model.dense.inputs import DenseInputs, encode_items, encode_part
from nsrmp_bench.reference_model.dense.model import DenseNet
from nsrmp_bench.reference_model.training import Stage
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["MODEL_ID", "MODEL_ID_5X", "Dense5xConfig", "Dense5xPredictor", "DenseConfig",
           "DensePredictor", "val_accuracy"]

MODEL_ID = "dense-v1"
MODEL_ID_5X = "dense5x-v1"
LABEL = "not CLIPort"


def val_accuracy(model: DenseNet, enc: DenseInputs) -> tuple[float, float]:
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


def _loss(model: DenseNet, enc: DenseInputs, rows: Tensor) -> Tensor:
    assert enc.pick is not None and enc.place is not None
    x = model.image_input(enc.image(rows))
    text = model.text(enc.tokens_of(rows))
    pick, place = enc.pick[rows], enc.place[rows]
    return (F.cross_entropy(model.pick_logits(x, text), pick)
            + F.cross_entropy(model.place_logits(x, text, pick), place))


class DensePredictor(PredictionModel):
    """``dense-v1``: trains on the single-step episodes of ``data/train``, selects on those
    of ``data/val``; predicts from what ``EpisodeDataset`` gives as ``inputs``.

    A single-step model: on a multi-step episode it predicts one pick and place for the
    whole instruction (one object moved, the others where they were)."""

    model_id = MODEL_ID
    kind = Kind.DENSE
    label = LABEL
    config_cls: ClassVar[type[ModelConfig]] = DenseConfig
    supervision = ("the moved object's initial and final box centres (pick and place "
                   "pixels) of single-step episodes; nothing else")
    inputs = ("instruction text, initial RGB, initial depth (pooled by scale); the "
              "initial (gold) boxes only to snap the pick to an object and to move its box")
    data_hint = "e.g. data/paper-v2 (dense) or data/dense5x-v2 (dense5x)"
    tiny_overrides: ClassVar[dict[str, object]] = {
        "epochs": 3, "batch_size": 4, "width": 8, "word_dim": 16, "text_hidden": 16,
        "val": "val", "val_limit": 8, "read_workers": 1}
    config: DenseConfig
    model: DenseNet

    @classmethod
    def build_network(cls, config: DenseConfig, vocab_size: int,
                      state: Mapping[str, Tensor]) -> DenseNet:
        return DenseNet(vocab_size, config)

    @classmethod
    def check_data(cls, data: Path, config: DenseConfig) -> None:
        super().check_data(data, config)
        val_dir = (data / config.val).resolve()
        if not (val_dir / "manifest.json").exists():
            msg = (f"the validation part {val_dir} (--data {data} + val {config.val!r}) is "
                   "not a finished part; pass --set val=PATH relative to --data (dense5x-v2 "
                   "has no val: it selects on ../paper-v2/val beside it)")
            raise InvalidArgument(msg)

    @classmethod
    def plan_training(cls, data: Path, config: DenseConfig, seed: int) -> TrainingPlan:
        cfg = config
        train_dir, val_dir = data / "train", (data / cfg.val).resolve()
        t0 = time.perf_counter()
        train, vocab = encode_part(train_dir, None, cfg.scale, single_step=True, targets=True,
                                   workers=cfg.read_workers)
        val, _ = encode_part(val_dir, vocab, cfg.scale, single_step=True, targets=True,
                             limit=cfg.val_limit)
        read_seconds = time.perf_counter() - t0
        model = DenseNet(len(vocab), cfg)
        last: dict[str, float] = {}

        def validate(stage: Stage) -> float:
            ident, place = val_accuracy(model, val)
            last.update(identification=ident, placement=place)
            return (ident + place) / 2

        stage = Stage("dense", cfg.epochs, torch.arange(len(train)),
                      lambda: list(model.parameters()), lambda rows: _loss(model, train, rows),
                      cfg.lr, cfg.batch_size, uses_splitter=True)
        return TrainingPlan(
            network=model, stages=[stage], validate=validate,
            training_data=(f"{len(train)} single-step episodes of {train_dir}; selection on "
                           f"the first {len(val)} single-step episodes of {val_dir.name} "
                           f"({val_dir.parent.name})"),
            vocab=vocab.to_list(), score_name="val_id_pl", read_seconds=read_seconds,
            checkpoint_extra=lambda: {"val": {k: round(v, 4) for k, v in last.items()}})

    def infer(self, items: Sequence[dict[str, Any]]) -> tuple[DenseInputs, Inferred]:
        """Encode the items' inputs and run the model."""
        self.set_threads()
        enc, _ = encode_items(items, self.vocab, self.config.scale, targets=False)
        return enc, infer(self.model, enc)

    def predict(self, items: Sequence[dict[str, Any]], camera: Camera) -> Iterator[Prediction]:
        """Predictions (boxes, pick, place) for dataset items (``{"id", "inputs"}``).

        ``camera`` is not used: pick and place are pixels, as the boxes are."""
        del camera
        enc, res = self.infer(items)
        for i, eid in enumerate(enc.ids):
            yield Prediction(id=eid, boxes=res.boxes[i],
                             pick=(float(res.picks[i, 0]), float(res.picks[i, 1])),
                             place=(float(res.places[i, 0]), float(res.places[i, 1])))


class Dense5xPredictor(DensePredictor):
    """``dense5x-v1``: as ``dense-v1`` on ``data/train`` (dense5x-v2), selecting on
    ``data/../paper-v2/val`` (the config's ``val``)."""

    model_id = MODEL_ID_5X
    label = "not CLIPort, 5x data"
    config_cls = Dense5xConfig
