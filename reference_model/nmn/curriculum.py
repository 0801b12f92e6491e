"""NMN+'s curriculum, after the original's stages (``reference/nsrm-original-model.md``
§2.3: single-step, then the splitter, then multi-step), with NSRM's loss:

1. ``single``: single-step instructions (relational ones included); soft attention
   trains everything but the splitter end to end: CNN, language encoder, attention,
   action decoder and action simulator.
2. ``splitter``: the CNN is frozen from here on (its features are computed once); a
   seeded subset of the instructions; every split point (and "no split") is scored by its
   box loss under the hard model, and the splitter learns the softmin of those losses
   (NSRM's splitter stage, :func:`~reference_model.nsrm.curriculum.split_choice_loss`).
3. ``multistep``: every instruction, split by the splitter, each piece executed in order
   with soft attention; everything but the CNN and the splitter learns.

The single stage selects its episodes by the split's number of steps (data selection, as
in the original); the model never reads it.
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

from nsrmp_bench.reference_model.encoded import Encoded
from nsrmp_bench.reference_model.nmn.config import NMNConfig
from nsrmp_bench.reference_model.nmn.model import NMN
from nsrmp_bench.reference_model.nsrm.curriculum import feature_cache, split_choice_loss
from nsrmp_bench.reference_model.nsrm.inference import split_recursively
from nsrmp_bench.reference_model.nsrm.loss import box_loss, execution_loss
from nsrmp_bench.reference_model.nsrm.model import split_pieces
from nsrmp_bench.reference_model.training import Stage

__all__ = ["build_stages"]


class _Steps:
    def __init__(self, model: NMN, data: Encoded, cfg: NMNConfig) -> None:
        self.model, self.data, self.cfg = model, data, cfg
        self.cache: Tensor | None = None

    def freeze_visual(self) -> None:
        """From here on the CNN is frozen: compute every training object's features once."""
        self.cache = feature_cache(self.model, self.model.features, self.data)

    def _batch(self, rows: Tensor) -> tuple[Encoded, Tensor, Tensor]:
        b = self.data.select(rows)
        assert b.final_boxes is not None
        n = b.object_mask.shape[1]
        feats = self.model.features(b) if self.cache is None else self.cache[rows, :n]
        return b, feats, b.final_boxes

    def soft(self, rows: Tensor, split: bool = False) -> Tensor:
        b, feats, gold = self._batch(rows)
        if split:
            with torch.no_grad():
                was = self.model.training
                self.model.eval()
                cuts = split_recursively(self.model, b.tokens, self.cfg.max_steps)
                self.model.train(was)
            pieces, pmask = split_pieces(b.tokens, cuts)
        else:
            pieces, pmask = b.tokens[:, None, :], torch.ones((len(b), 1), dtype=torch.bool)
        ex = self.model.execute(feats, b.geometry, b.object_mask, pieces, pmask, hard=False)
        return execution_loss(self.model.simulator, ex.world, ex.subjects, ex.bases,
                              ex.actions, pmask, b.geometry, b.boxes, gold, b.object_mask,
                              b.image_size).mean()

    def splitter(self, rows: Tensor) -> Tensor:
        b, feats, gold = self._batch(rows)

        def option_losses(idx: Tensor, pieces: Tensor, pmask: Tensor) -> Tensor:
            ex = self.model.execute(feats[idx], b.geometry[idx], b.object_mask[idx], pieces,
                                    pmask, hard=True)
            return box_loss(ex.world, gold[idx], b.object_mask[idx], b.image_size)

        return split_choice_loss(self.model, self.model.splitter, b.tokens, option_losses)


def _params(*mods: nn.Module) -> list[nn.Parameter]:
    return [p for m in mods for p in m.parameters()]


def build_stages(model: NMN, data: Encoded, cfg: NMNConfig) -> list[Stage]:
    """The curriculum over the training episodes ``data`` (with targets and categories)."""
    s = _Steps(model, data, cfg)
    single = torch.nonzero(data.meta["steps"] == 1).flatten()
    every = torch.arange(len(data))
    gen = torch.Generator().manual_seed(len(data))
    subset = every[torch.randperm(len(data), generator=gen)[: cfg.splitter_examples]]
    m = model
    core = lambda: _params(m.visual, m.encoder, m.subject, m.base, m.action,  # noqa: E731
                           m.simulator)
    rest = lambda: _params(m.encoder, m.subject, m.base, m.action, m.simulator)  # noqa: E731
    bs, lr = cfg.batch_size, cfg.lr
    return [
        Stage("single", cfg.epochs_single, single, core, s.soft, lr, bs),
        Stage("splitter", cfg.epochs_splitter, subset, lambda: _params(m.splitter),
              s.splitter, lr, bs, uses_splitter=True, start=s.freeze_visual),
        Stage("multistep", cfg.epochs_multistep, every, rest,
              lambda rows: s.soft(rows, split=True), lr / 2, bs, uses_splitter=True,
              start=s.freeze_visual),
    ]
