"""The one training loop every learned model uses: stages of epochs over seeded batches,
a rich progress bar per stage (loss, validation score, time left), a JSONL log, and a
checkpoint after every epoch from which an interrupted run resumes.

A model's curriculum is a list of :class:`Stage`; each has a name, a number of epochs,
the training rows it draws batches from, the parameters it trains and a ``step`` that
returns the batch loss (the loop does backward and the optimiser step).
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from torch import Tensor, nn

from nsrmp_bench.reference_model.checkpoints import read_torch_file

__all__ = ["Stage", "TrainState", "train_stages"]

CHECKPOINT = "last.pt"
LOG = "log.jsonl"


@dataclass
class Stage:
    """One curriculum stage."""

    name: str
    epochs: int
    rows: Tensor  # indices of the training episodes this stage uses
    parameters: Callable[[], list[nn.Parameter]]
    step: Callable[[Tensor], Tensor]  # batch rows -> loss (scalar, with grad)
    lr: float
    batch_size: int
    uses_splitter: bool = False  # validate with the splitter (from its stage on)
    start: Callable[[], None] | None = None  # called when the stage begins (or resumes)
    # the learning rate falls from lr to 0 over the stage on a half cosine, batch by batch
    decay: bool = False


@dataclass
class TrainState:
    """Where a run stands: finished (stage, epoch) pairs, and the best validation score."""

    stage: int = 0
    epoch: int = 0
    best: float = float("-inf")
    seconds: float = 0.0


def _save(path: Path, payload: dict[str, Any]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    torch.save(payload, tmp)
    with open(tmp, "rb") as fh:
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def train_stages(model: nn.Module, stages: Sequence[Stage], out: Path, *, seed: int,
                 validate: Callable[[Stage], float | tuple[float, dict[str, float]]],
                 on_best: Callable[[], None],
                 quiet: bool = False, score_name: str = "val IoU-M") -> TrainState:
    """Run ``stages`` (resuming from ``out/last.pt`` if there), selecting on ``validate``.

    ``validate`` returns the validation score of the model (higher is better) after each
    epoch of a stage, or the score and more validation figures for the log;
    ``on_best`` is called when it improves (the caller writes its best checkpoint); only
    stages that validate the model as it is used (``uses_splitter``) take part, and if none
    ran, the last model is the one kept. ``score_name`` names the score on the progress bar
    and, in snake case, in the log (``val_iou_m``).
    """
    log_key = score_name.lower().replace(" ", "_").replace("-", "_")
    out.mkdir(parents=True, exist_ok=True)
    state = TrainState()
    ckpt = out / CHECKPOINT
    resume: dict[str, Any] | None = None
    if ckpt.exists():
        resume = read_torch_file(ckpt, "resume file")
        model.load_state_dict(resume["model"])
        state = TrainState(**resume["state"])
    log = (out / LOG).open("a", encoding="utf-8")
    try:
        for si, stage in enumerate(stages):
            if si < state.stage:
                continue
            if stage.start is not None:
                stage.start()
            params = stage.parameters()
            for p in model.parameters():
                p.requires_grad_(False)
            for p in params:
                p.requires_grad_(True)
            optim = torch.optim.Adam(params, lr=stage.lr)
            if resume is not None and resume["state"]["stage"] == si and "optim" in resume:
                optim.load_state_dict(resume["optim"])
            resume = None
            n_batches = max(1, len(stage.rows) // stage.batch_size)
            with Progress(TextColumn("{task.description}"), BarColumn(),
                          TextColumn("{task.fields[info]}"), TimeElapsedColumn(),
                          TextColumn("left"), TimeRemainingColumn(), disable=quiet) as bar:
                task = bar.add_task(f"{stage.name}", total=stage.epochs * n_batches,
                                    completed=state.epoch * n_batches, info="")
                for epoch in range(state.epoch, stage.epochs):
                    t0 = time.perf_counter()
                    gen = torch.Generator().manual_seed(seed * 1000 + si * 100 + epoch)
                    order = stage.rows[torch.randperm(len(stage.rows), generator=gen)]
                    torch.manual_seed(seed * 1000 + si * 100 + epoch)
                    model.train()
                    total = 0.0
                    for b in range(n_batches):
                        rows = order[b * stage.batch_size:(b + 1) * stage.batch_size]
                        if stage.decay:
                            done = (epoch * n_batches + b) / (stage.epochs * n_batches)
                            for group in optim.param_groups:
                                group["lr"] = stage.lr * 0.5 * (1.0 + math.cos(math.pi * done))
                        loss = stage.step(rows)
                        optim.zero_grad()
                        loss.backward()
                        nn.utils.clip_grad_norm_(params, 5.0)
                        optim.step()
                        total += float(loss.detach())
                        bar.update(task, advance=1, info=f"loss {total / (b + 1):.3f}")
                    found = validate(stage)
                    score, more = found if isinstance(found, tuple) else (found, {})
                    state.seconds += time.perf_counter() - t0
                    # select only among models that run as they will be used
                    improved = stage.uses_splitter and score > state.best
                    if improved:
                        state.best = score
                        on_best()
                    state.epoch = epoch + 1
                    record = {"stage": stage.name, "epoch": epoch + 1,
                              "loss": round(total / n_batches, 5), log_key: round(score, 5),
                              "best": improved, "seconds": round(state.seconds, 1),
                              **{k: round(v, 5) for k, v in more.items()}}
                    _save(ckpt, {"model": model.state_dict(), "optim": optim.state_dict(),
                                 "state": {**state.__dict__, "stage": si}})
                    log.write(json.dumps(record) + "\n")  # after the checkpoint it records
                    log.flush()
                    bar.update(task, info=f"loss {total / n_batches:.3f}  {score_name} {score:.3f}")
            state.stage, state.epoch = si + 1, 0
            _save(ckpt, {"model": model.state_dict(), "state": dict(state.__dict__)})
        if state.best == float("-inf"):  # no selecting stage ran: keep the last model
            on_best()
    finally:
        log.close()
    return state
