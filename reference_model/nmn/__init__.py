"""NMN+, the paper's attention baseline (``nmn-v1``): train it, load it, predict.

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
from nsrmp_bench.reference_model.nmn.config import NMNConfig
from nsrmp_bench.reference_model.nmn.curriculum import build_stages
from nsrmp_bench.reference_model.nmn.model import NMN, infer
from nsrmp_bench.reference_model.nsrm.inference import (
    Inferred,
    ProgramPredictor,
    inferred_iou_m,
)
from nsrmp_bench.reference_model.training import train_stages

__all__ = ["MODEL_ID", "NMNConfig", "NMNPredictor", "train_nmn"]

MODEL_ID = "nmn-v1"


def train_nmn(data: Path, out: Path, *, seed: int = 0, config: NMNConfig | None = None,
              quiet: bool = False) -> Path:
    """Train on ``data/train``, select on ``data/val``; returns ``out/best.pt``.

    A split without a val part (attributes-v2) selects on the last tenth of its train part,
    which is then not trained on.
    """
    cfg = config or NMNConfig()
    torch.set_num_threads(cfg.threads)
    torch.manual_seed(seed)
    t0 = time.perf_counter()
    c0 = time.process_time()
    train, val, vocab = encode_train_val(data)
    model = NMN(len(vocab), cfg)
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.json").write_text(json.dumps(cfg.to_dict(), indent=1) + "\n", "utf-8")
    best = out / "best.pt"

    def on_best() -> None:
        save_checkpoint(best, MODEL_ID, cfg.to_dict(), vocab.to_list(), model.state_dict(),
                        {"seed": seed, "data": str(data)})

    def validate(uses_splitter: bool) -> float:
        return inferred_iou_m(val, infer(model, val, split=uses_splitter))

    state = train_stages(model, build_stages(model, train, cfg), out, seed=seed,
                         validate=lambda stage: validate(stage.uses_splitter),
                         on_best=on_best, quiet=quiet)
    n_params = sum(p.numel() for p in model.parameters())
    write_card(out / "card.json", {
        "model": MODEL_ID,
        "training_data": f"{len(train)} training episodes (train part); selection on val",
        "train_seconds": round(state.seconds, 1),
        "wall_seconds": round(time.perf_counter() - t0, 1),
        "cpu_seconds": round(time.process_time() - c0, 1),
        "parameters": n_params, "best_val_iou_m": round(state.best, 4), "seed": seed,
        "threads": cfg.threads,
        "supervision": "initial and final boxes only (no gold program, no intermediate "
                       "state, no template id, no reference labels); the single-step stage "
                       "selects episodes by number of steps",
        "inputs": "instruction text, initial RGB, initial depth, initial (gold) boxes",
        "config": cfg.to_dict(),
    })
    return best


class NMNPredictor(ProgramPredictor):
    """A loaded NMN+: predicts from what ``EpisodeDataset`` gives as ``inputs`` only."""

    model_id = MODEL_ID
    model: NMN

    def read_config(self, data: Mapping[str, Any]) -> NMNConfig:
        return NMNConfig.from_dict(dict(data))

    def build(self, vocab_size: int) -> NMN:
        return NMN(vocab_size, self.config)

    def run(self, enc: Encoded) -> Inferred:
        return infer(self.model, enc)
