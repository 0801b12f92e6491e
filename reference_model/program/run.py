"""Training and loading a program model (NSRM v2, NMN+ v2): one function each, given
the model's id and how to build its step model.

Training reads ``data/train`` (selection on ``data/val``; a split without val selects on
the last tenth of train), fits the action rule, derives each episode's consistent
programs from its boxes, then runs two stages through the shared loop
(:func:`~nsrmp_bench.reference_model.training.train_stages`): ``single`` (one-step
programs where one box changed) and ``joint`` (splitter and step model on every episode).
Selection is on the in-loop val IoU-M of the model as it predicts (splitter included),
in the joint stage.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, cast

import torch

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.reference_model.checkpoints import load_checkpoint, save_checkpoint, write_card
from nsrmp_bench.reference_model.encoded import encode_targets
from nsrmp_bench.reference_model.program.data import (
    ProgramData,
    fit_part_rule,
    part_camera,
    program_data,
    read_items,
    with_training_signal,
)
from nsrmp_bench.reference_model.program.inference import (
    Decoded,
    Oracle,
    decode,
    decoded_iou_m,
    decoded_predictions,
)
from nsrmp_bench.reference_model.program.modules import ProgramModel, Splitter, StepModel
from nsrmp_bench.reference_model.program.scene3d import ActionRule
from nsrmp_bench.reference_model.program.training import joint_loss, single_loss
from nsrmp_bench.reference_model.tokens import Vocabulary
from nsrmp_bench.reference_model.training import Stage, train_stages
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["INPUTS", "SUPERVISION", "ProgramPredictor", "train_program_model"]

SUPERVISION = (
    "initial and final boxes only: the programs consistent with them under the action "
    "rule (no gold program, no lexed form, no template id, no reference labels, no step "
    "counts or categories)")
INPUTS = "instruction text, initial RGB, initial depth, initial (gold) boxes, the camera"


def _parts(data: Path) -> tuple[Path, Path | None]:
    if not (data / "train" / "manifest.json").exists():
        msg = (f"{data} has no finished part 'train' ({data / 'train'}); pass a split root "
               "holding train/ (and val/), e.g. generate one with `nsrmp-bench generate "
               "--split paper-v2 --out data/paper-v2`")
        raise InvalidArgument(msg)
    val = data / "val"
    return data / "train", val if (val / "manifest.json").exists() else None


def train_program_model(model_id: str, build: Callable[[int], StepModel], cfg: Any,
                        data: Path, out: Path, *, seed: int, quiet: bool) -> Path:
    """Train a program model (see the module doc); returns ``out/best.pt``."""
    torch.set_num_threads(int(cfg.threads))
    torch.manual_seed(seed)
    t0 = time.perf_counter()
    train_dir, val_dir = _parts(data)
    items, ds = read_items(train_dir)
    vocab = Vocabulary.build(str(it["inputs"]["instruction"]) for it in items)
    camera = part_camera(train_dir)
    cats = ds.collection.index.set_index("id").to_dict("index")
    if val_dir is None:
        cut = len(items) - max(1, len(items) // 10)
        items, val_items, val_cats = items[:cut], items[cut:], cats
    else:
        val_items, vds = read_items(val_dir)
        val_cats = vds.collection.index.set_index("id").to_dict("index")
    # the states depend on the rule's fixed centre only, so one encoding serves the fit
    train = program_data(items, vocab, camera, ActionRule())
    encode_targets(train.enc, items, cats)
    rule = fit_part_rule(train)
    train = with_training_signal(train, items, cats, rule)
    val = with_training_signal(program_data(val_items, vocab, camera, rule), val_items,
                               val_cats, rule)
    torch.manual_seed(seed)
    model = ProgramModel(build(len(vocab)), Splitter(len(vocab)))
    model.rule = rule
    out.mkdir(parents=True, exist_ok=True)
    _write_json(out / "config.json", cfg.to_dict())
    best = out / "best.pt"
    assert train.consistent is not None and train.moved is not None
    single_rows = torch.tensor([i for i, c in enumerate(train.consistent)
                                if train.moved[i] == 1 and len(c.one)], dtype=torch.long)
    joint_rows = torch.tensor([i for i, c in enumerate(train.consistent)
                               if len(c.one) or len(c.two)], dtype=torch.long)

    def single(rows: torch.Tensor) -> torch.Tensor:
        return single_loss(model.step, train, rows.tolist())

    def joint(rows: torch.Tensor) -> torch.Tensor:
        return joint_loss(model.step, model.splitter, train, rows.tolist())

    stages = [
        Stage("warmup", int(cfg.epochs_warmup), single_rows, model.step.warmup_parameters,
              single, float(cfg.lr), int(cfg.batch_size)),
        Stage("single", int(cfg.epochs_single), single_rows,
              lambda: list(model.step.parameters()), single, float(cfg.lr),
              int(cfg.batch_size)),
        Stage("joint", int(cfg.epochs_joint), joint_rows, lambda: list(model.parameters()),
              joint, float(cfg.lr) / 2, int(cfg.batch_size), uses_splitter=True),
    ]

    gold = [[tuple(int(x) for x in row) for row in it["targets"]["grounded"].tolist()]
            for it in val_items]  # for the log's figures only

    def validate(stage: Stage) -> tuple[float, dict[str, float]]:
        decoded = decode(model.step, model.splitter, val, rule)
        return decoded_iou_m(val, decoded), validation_figures(val, decoded, gold)

    def on_best() -> None:
        save_checkpoint(best, model_id, cfg.to_dict(), vocab.to_list(), model.state_dict(),
                        {"seed": seed, "data": str(data)})

    state = train_stages(model, stages, out, seed=seed, validate=validate, on_best=on_best,
                         quiet=quiet)
    n_params = sum(p.numel() for p in model.parameters())
    write_card(out / "card.json", {
        "model": model_id, "train_seconds": round(state.seconds, 1),
        "wall_seconds": round(time.perf_counter() - t0, 1), "parameters": n_params,
        "best_val_iou_m": round(state.best, 4), "seed": seed, "threads": int(cfg.threads),
        "training_data": f"{len(train)} training episodes ({len(single_rows)} with one "
                         f"changed box in the single stage); selection on "
                         f"{'val' if val_dir is not None else 'the last tenth of train'}",
        "action_rule": rule.to_dict(), "config": cfg.to_dict(),
        "supervision": SUPERVISION, "inputs": INPUTS,
    })
    return best


def validation_figures(data: ProgramData, decoded: Decoded,
                       gold: list[list[tuple[int, ...]]]) -> dict[str, float]:
    """The log's validation figures: subject accuracy (all steps) on episodes with and
    without relational references, and split accuracy (the right number of steps)."""
    hit = {True: [0, 0], False: [0, 0]}
    split = 0
    relational = data.enc.meta["relational"].tolist()
    for steps, want, rel in zip(decoded.steps, gold, relational, strict=True):
        split += len(steps) == len(want)
        for k, (_, subject, _) in enumerate(want):
            hit[bool(rel)][1] += 1
            hit[bool(rel)][0] += k < len(steps) and steps[k][1] == subject
    return {"val_subject_relational": hit[True][0] / max(hit[True][1], 1),
            "val_subject_attribute": hit[False][0] / max(hit[False][1], 1),
            "val_split": split / max(len(gold), 1)}


def _write_json(path: Path, data: dict[str, Any]) -> None:
    import os

    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(json.dumps(data, indent=1) + "\n")
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


class ProgramPredictor:
    """A loaded program model: predicts from what ``EpisodeDataset`` gives as ``inputs``."""

    model_id: str
    config_cls: Callable[..., Any]

    def __init__(self, checkpoint: Path,
                 build: Callable[[int, Any], StepModel]) -> None:
        payload = load_checkpoint(checkpoint, self.model_id)
        self.checkpoint = Path(checkpoint)
        self.config = self.config_cls(**payload["config"])
        self.vocab = Vocabulary(tuple(payload["vocab"]))
        self.model = ProgramModel(build(len(self.vocab), self.config),
                                  Splitter(len(self.vocab)))
        self.model.load_state_dict(payload["state"])
        self.rule = self.model.rule
        self.model.eval()
        torch.set_num_threads(int(self.config.threads))

    def data(self, items: list[dict[str, Any]], camera: Camera) -> ProgramData:
        """The items prepared for the model (inputs only)."""
        return program_data(items, self.vocab, camera, self.rule)

    def predict(self, items: list[dict[str, Any]], camera: Camera,
                oracle: Oracle | None = None) -> Iterator[Prediction]:
        """Predictions for ``items`` (``oracle``: the diagnosis's gold substitutions)."""
        data = self.data(items, camera)
        decoded = decode(self.model.step, self.model.splitter, data, self.rule, oracle)
        ids = [str(it["id"]) for it in items]
        return cast(Iterator[Prediction], decoded_predictions(ids, data, decoded, camera))
