"""Several program models trained apart (seeds), read as one (``members`` > 1 in a config).

A program model overfits its training instructions by the end of the joint stage (the
loss falls to about zero) and where it goes wrong moves from seed to seed: two seeds of
the same configuration scored 0.822 and 0.832 on val, and the grounding misses of one are
mostly not the other's. Read together, the members' errors mostly cancel:

- :class:`EnsembleStep` is a step model whose subject, base and action log-probabilities
  are the mean of its members' (their product, renormalised by nothing: decoding takes the
  argmax). Its features and codes are the members' side by side, so that the decoder
  (:func:`~.inference.decode`) and the oracle ladder run it as any step model.
- :class:`EnsembleSplitter` cuts where the mean of its members' boundary probabilities
  peaks, at the mean of their fitted thresholds (and their one ``gap``).

Members train in parallel, one process each (:func:`train_members`), each a whole run of
its own (resumable, selected on val as any run) in ``out/member-K``; the ensemble is then
put together from their best checkpoints and validated once (see ``run.py``).
"""

from __future__ import annotations

import multiprocessing as mp
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import torch
from torch import Tensor, nn

from nsrmp_bench.reference_model.base import BEST, CONFIG
from nsrmp_bench.reference_model.program.modules import Splitter, StepModel, StepOutput

__all__ = ["EnsembleSplitter", "EnsembleStep", "member_dirs", "member_seeds", "train_members"]


class EnsembleStep(StepModel):
    """Step models read as one: their log-probabilities averaged."""

    def __init__(self, members: Sequence[StepModel]) -> None:
        super().__init__()
        self.members = nn.ModuleList(members)

    def features(self, crops: Tensor, mask: Tensor, sizes: Tensor) -> Tensor:
        return torch.cat([m.features(crops, mask, sizes) for m in self._steps()], -1)

    def code(self, pieces: Tensor) -> Tensor:
        return torch.cat([m.code(pieces) for m in self._steps()], -1)

    def step(self, code: Tensor, tokens: Tensor, feats: Tensor, centres: Tensor,
             previous: Tensor, mask: Tensor) -> StepOutput:
        k = len(self.members)
        outs = [m.step(c, tokens, f, centres, previous, mask) for m, c, f in
                zip(self._steps(), code.chunk(k, -1), feats.chunk(k, -1), strict=True)]
        subject, base, action = (torch.stack(parts).mean(0) for parts in zip(*outs,
                                                                               strict=True))
        return subject, base, action

    def _steps(self) -> list[StepModel]:
        return [m for m in self.members if isinstance(m, StepModel)]


class EnsembleSplitter(Splitter):
    """Splitters read as one: the mean of their boundary probabilities, cut at the mean of
    their thresholds (every member is a calibrated :class:`Splitter`; this one has no
    encoder of its own, so it does not call :class:`Splitter`'s constructor)."""

    def __init__(self, members: Sequence[Splitter]) -> None:
        nn.Module.__init__(self)
        gaps = sorted({m.gap for m in members})
        if len(gaps) != 1:
            msg = (f"an ensemble's splitters must share one gap, got {gaps}; train the "
                   f"members with one splitter_gap")
            raise ValueError(msg)
        self.gap = gaps[0]
        self.members = nn.ModuleList(members)
        self.register_buffer("calibration", torch.tensor([1.0, 0.0]))
        # a buffer, so that the checkpoint carries it (loading restores the trained value)
        self.register_buffer("threshold",
                             torch.stack([m.threshold for m in self._splitters()]).mean())

    def forward(self, tokens: Tensor) -> Tensor:
        probs = torch.stack([torch.sigmoid(m(tokens)) for m in self._splitters()]).mean(0)
        return torch.logit(probs)  # -inf where every member says -inf (no step starts)

    def _splitters(self) -> list[Splitter]:
        return [m for m in self.members if isinstance(m, Splitter)]


def member_seeds(seed: int, members: int) -> list[int]:
    """The members' seeds: run seed 0 of 3 members trains seeds 0, 1, 2; seed 1, 3, 4, 5."""
    return [seed * members + k for k in range(members)]


def member_dirs(out: Path, members: int) -> list[Path]:
    """Where each member's run lives."""
    return [out / f"member-{k}" for k in range(members)]


def _train_member(model_id: str, data: str, out: str, config: dict[str, Any], seed: int,
                  restart: bool) -> None:
    """One member's whole run, in its own (spawned) process."""
    from nsrmp_bench.reference_model.registry import get_model

    cls = get_model(model_id).model_cls()
    cfg = cls.config_cls.from_dict(config)
    cls.train(Path(data), Path(out), seed=seed, config=cfg, quiet=True, restart=restart)


def train_members(model_id: str, data: Path, out: Path, config: dict[str, Any],
                  seed: int, members: int, restart: bool) -> list[Path]:
    """Train the members of a run in parallel, one spawned process each, each starting
    once the one before it has read the data (a member killed with the rest resumes from
    its ``last.pt`` when the run is started again, then they start at once; ``restart``
    starts them over); returns their ``best.pt``. A member that fails fails the run."""
    ctx = mp.get_context("spawn")
    dirs = member_dirs(out, members)
    procs = [ctx.Process(target=_train_member, name=f"{model_id} member {k}",
                         args=(model_id, str(data), str(d), config, s, restart))
             for k, (d, s) in enumerate(zip(dirs, member_seeds(seed, members), strict=True))]
    if restart:  # so that waiting below reads this run's configs, not a deleted run's
        for d in dirs:
            (d / CONFIG).unlink(missing_ok=True)
    try:
        for d, p in zip(dirs, procs, strict=True):
            p.start()
            # the next member starts once this one has read the data (it writes its
            # config.json then): reading holds every episode's images, twice a
            # training's memory (6.7 GB against 3.3 GB on paper-v2), so three members
            # reading at once would need 20 GB
            while p.is_alive() and not (d / CONFIG).exists():
                time.sleep(0.5)
        for p in procs:
            p.join()
    finally:
        for p in procs:
            if p.is_alive():
                p.terminate()
                p.join()
    failed = [f"member {k} (exit {p.exitcode})" for k, p in enumerate(procs) if p.exitcode]
    if failed:
        msg = (f"training {model_id} in {out} failed: {', '.join(failed)}; its log is in "
               f"{out}/member-K/; run the same command again to resume")
        raise RuntimeError(msg)
    return [d / BEST for d in dirs]
