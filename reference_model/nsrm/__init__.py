"""NSRM, the neuro-symbolic reference model (``nsrm-v1``): train it, load it, predict.

See ``MODEL_CARD.md`` beside this file for what it reads, how it is supervised and how it
is trained.
"""

from __future__ import annotations

import json
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from nsrmp_bench.reference_model.checkpoints import save_checkpoint, write_card
from nsrmp_bench.reference_model.encoded import Encoded, encode_train_val
from nsrmp_bench.reference_model.nsrm.config import NSRMConfig
from nsrmp_bench.reference_model.nsrm.curriculum import build_stages
from nsrmp_bench.reference_model.nsrm.inference import (
    Inferred,
    ProgramPredictor,
    infer,
    inferred_iou_m,
)
from nsrmp_bench.reference_model.nsrm.model import NSRM
from nsrmp_bench.reference_model.training import train_stages

__all__ = ["MODEL_ID", "NSRMConfig", "NSRMPredictor", "train_nsrm", "val_iou_m"]

MODEL_ID = "nsrm-v1"


def val_iou_m(model: NSRM, enc: Encoded, split: bool = True) -> float:
    """The in-loop validation IoU-M (:func:`~.inference.inferred_iou_m`) of ``model``."""
    return inferred_iou_m(enc, infer(model, enc, split=split))


def train_nsrm(data: Path, out: Path, *, seed: int = 0, config: NSRMConfig | None = None,
               quiet: bool = False) -> Path:
    """Train on ``data/train``, select on ``data/val``; returns ``out/best.pt``.

    A split without a val part (attributes-v2) selects on the last tenth of its train part,
    which is then not trained on.
    """
    cfg = config or NSRMConfig()
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(seed)
    t0 = time.perf_counter()
    train, val, vocab = encode_train_val(data)
    model = NSRM(len(vocab), cfg)
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.json").write_text(json.dumps(cfg.to_dict(), indent=1) + "\n", "utf-8")
    best = out / "best.pt"

    def on_best() -> None:
        save_checkpoint(best, MODEL_ID, cfg.to_dict(), vocab.to_list(), model.state_dict(),
                        {"seed": seed, "data": str(data)})

    state = train_stages(model, build_stages(model, train, cfg), out, seed=seed,
                         validate=lambda stage: val_iou_m(model, val, stage.uses_splitter),
                         on_best=on_best, quiet=quiet)
    n_params = sum(p.numel() for p in model.parameters())
    write_card(out / "card.json", model_card(len(train), state.seconds, n_params, state.best,
                                             time.perf_counter() - t0, cfg, seed))
    return best


def model_card(n_train: int, train_seconds: float, n_params: int, best: float,
               wall: float, cfg: NSRMConfig, seed: int) -> dict[str, Any]:
    """The model card of a training run."""
    return {
        "model": MODEL_ID,
        "training_data": f"{n_train} training episodes (train part); selection on val",
        "train_seconds": round(train_seconds, 1), "wall_seconds": round(wall, 1),
        "parameters": n_params, "best_val_iou_m": round(best, 4), "seed": seed,
        "threads": cfg.threads,
        "supervision": "initial and final boxes only (no gold program, no intermediate "
                       "state, no template id, no lexed slots, no reference labels); the "
                       "curriculum selects episodes by number of steps and relational flag",
        "inputs": "instruction text, initial RGB, initial depth, initial (gold) boxes",
        "config": cfg.to_dict(),
    }


class NSRMPredictor(ProgramPredictor):
    """A loaded NSRM: predicts from what ``EpisodeDataset`` gives as ``inputs`` only."""

    model_id = MODEL_ID
    model: NSRM

    def read_config(self, data: Mapping[str, Any]) -> NSRMConfig:
        return NSRMConfig.from_dict(dict(data))

    def build(self, vocab_size: int) -> NSRM:
        return NSRM(vocab_size, self.config)

    def run(self, enc: Encoded) -> Inferred:
        return infer(self.model, enc)
