"""The dense baseline (not CLIPort): a from-scratch, Transporter-style two-stream FCN that
reads the initial RGB-D and the instruction and predicts a pick and a place heatmap.

Two registered ids share this module: ``dense-v1`` (trained on the single-step episodes
of paper-v2/train) and ``dense5x-v1`` (on dense5x-v2/train, five times as many, selected
on paper-v2/val). See ``MODEL_CARD.md`` beside this file.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import torch
import torch.nn.functional as F
from torch import Tensor

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.reference_model.checkpoints import load_checkpoint, save_checkpoint, write_card
from nsrmp_bench.reference_model.dense.config import Dense5xConfig, DenseConfig
from nsrmp_bench.reference_model.dense.inference import Inferred, infer
from nsrmp_bench.reference_model.dense.inputs import DenseInputs, encode_items, encode_part
from nsrmp_bench.reference_model.dense.model import DenseNet
from nsrmp_bench.reference_model.tokens import Vocabulary
from nsrmp_bench.reference_model.training import Stage, train_stages
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["MODEL_ID", "MODEL_ID_5X", "Dense5xConfig", "Dense5xPredictor", "DenseConfig",
           "DensePredictor", "train_dense", "train_dense5x", "val_accuracy"]

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


def _train(model_id: str, data: Path, out: Path, seed: int, cfg: DenseConfig,
           quiet: bool) -> Path:
    train_dir, val_dir = data / "train", (data / cfg.val).resolve()
    if not (train_dir / "manifest.json").exists():
        msg = (f"{data} has no finished part 'train' ({train_dir}); pass a split root "
               "holding train/, e.g. data/paper-v2 (dense) or data/dense5x-v2 (dense5x)")
        raise InvalidArgument(msg)
    if not (val_dir / "manifest.json").exists():
        msg = (f"the validation part {val_dir} (--data {data} + val {cfg.val!r}) is not a "
               "finished part; pass --set val=PATH relative to --data (dense5x-v2 has no "
               "val: it selects on ../paper-v2/val beside it)")
        raise InvalidArgument(msg)
    torch.set_num_threads(cfg.threads)
    t0 = time.perf_counter()
    train, vocab = encode_part(train_dir, None, cfg.scale, single_step=True, targets=True,
                               workers=cfg.read_workers)
    val, _ = encode_part(val_dir, vocab, cfg.scale, single_step=True, targets=True,
                         limit=cfg.val_limit)
    read_seconds = time.perf_counter() - t0
    torch.manual_seed(seed)
    model = DenseNet(len(vocab), cfg)
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.json").write_text(json.dumps(cfg.to_dict(), indent=1) + "\n", "utf-8")
    best = out / "best.pt"
    last: dict[str, float] = {}

    def validate(stage: Stage) -> float:
        ident, place = val_accuracy(model, val)
        last.update(identification=ident, placement=place)
        return (ident + place) / 2

    def on_best() -> None:
        save_checkpoint(best, model_id, cfg.to_dict(), vocab.to_list(), model.state_dict(),
                        {"seed": seed, "data": str(data), "val": {k: round(v, 4)
                                                                  for k, v in last.items()}})

    stage = Stage("dense", cfg.epochs, torch.arange(len(train)),
                  lambda: list(model.parameters()), lambda rows: _loss(model, train, rows),
                  cfg.lr, cfg.batch_size, uses_splitter=True)
    state = train_stages(model, [stage], out, seed=seed, validate=validate, on_best=on_best,
                         quiet=quiet, score_name="val_id_pl")
    n_params = sum(p.numel() for p in model.parameters())
    write_card(out / "card.json", {
        "model": model_id, "label": LABEL,
        "training_data": (f"{len(train)} single-step episodes of {train_dir}; selection on "
                          f"the first {len(val)} single-step episodes of {val_dir.name} "
                          f"({val_dir.parent.name})"),
        "train_seconds": round(state.seconds, 1),
        "wall_seconds": round(time.perf_counter() - t0, 1),
        "read_seconds": round(read_seconds, 1),
        "parameters": n_params, "best_val_id_pl": round(state.best, 4), "seed": seed,
        "threads": cfg.threads,
        "supervision": "the moved object's initial and final box centres (pick and place "
                       "pixels) of single-step episodes; nothing else",
        "inputs": "instruction text, initial RGB, initial depth (pooled by scale); the "
                  "initial (gold) boxes only to snap the pick to an object and to move its "
                  "box",
        "config": cfg.to_dict(),
    })
    return best


def train_dense(data: Path, out: Path, *, seed: int = 0, config: DenseConfig | None = None,
                quiet: bool = False) -> Path:
    """``dense-v1``: train on the single-step episodes of ``data/train``, select on those
    of ``data/val``; returns ``out/best.pt``."""
    return _train(MODEL_ID, data, out, seed, config or DenseConfig(), quiet)


def train_dense5x(data: Path, out: Path, *, seed: int = 0,
                  config: DenseConfig | None = None, quiet: bool = False) -> Path:
    """``dense5x-v1``: as :func:`train_dense` on ``data/train`` (dense5x-v2), selecting on
    ``data/../paper-v2/val`` (the config's ``val``)."""
    return _train(MODEL_ID_5X, data, out, seed, config or Dense5xConfig(), quiet)


class DensePredictor:
    """A loaded dense model: predicts from what ``EpisodeDataset`` gives as ``inputs``.

    A single-step model: on a multi-step episode it predicts one pick and place for the
    whole instruction (one object moved, the others where they were)."""

    model_id = MODEL_ID
    config_cls: type[DenseConfig] = DenseConfig

    def __init__(self, checkpoint: str | Path) -> None:
        payload = load_checkpoint(checkpoint, self.model_id)
        self.config = self.config_cls.from_dict(payload["config"])
        self.vocab = Vocabulary(tuple(payload["vocab"]))
        self.model = DenseNet(len(self.vocab), self.config)
        self.model.load_state_dict(payload["state"])
        self.model.eval()
        self.checkpoint = Path(checkpoint)

    def infer(self, items: Sequence[dict[str, Any]]) -> tuple[DenseInputs, Inferred]:
        """Encode the items' inputs and run the model."""
        torch.set_num_threads(self.config.threads)
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
    """A loaded ``dense5x-v1``."""

    model_id = MODEL_ID_5X
    config_cls = Dense5xConfig
