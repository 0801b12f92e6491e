"""NSRM's curriculum, after the paper's three stages (``reference/nsrm-original-model.md``
§1.10), with the steps that make it learn from scratch on a CPU:

1. ``attribute``: single-step, attribute-only instructions; the relaxed program (role
   probabilities as weights) trains everything end to end: parser, concepts, CNN and the
   action simulator.
2. ``relational``: single-step instructions, relational ones included, relaxed.
3. ``reinforce``: single-step; the CNN is frozen from here on (its features are computed
   once); discrete programs sampled from the parser, scored by their
   box loss; the parser learns by REINFORCE with the mean loss of the samples as baseline
   (the paper's), the executor from the loss of the samples weighted towards the best.
4. ``splitter``: a seeded subset of the instructions (1 and 2 steps); every split point
   (and "no split") is scored by its loss, each piece parsed and executed with the frozen
   argmax parser, and the splitter learns the softmin of those losses (cross-entropy).
   (The original's exact expected loss has vanishing gradients once the splitter settles
   on "no split", which it does while the pieces still parse badly: measured.)
5. ``multistep``: every instruction, split by the splitter; REINFORCE over the pieces'
   programs, so that later steps learn ``it``.

Stages select their episodes by the split's categories (number of steps, relational):
data selection, as in the paper; the model never reads them.
"""

from __future__ import annotations

from collections.abc import Callable

import torch
from torch import Tensor, nn

from nsrmp_bench.reference_model.encoded import Encoded
from nsrmp_bench.reference_model.nsrm.config import NSRMConfig
from nsrmp_bench.reference_model.nsrm.executor import StepParse
from nsrmp_bench.reference_model.nsrm.inference import split_recursively
from nsrmp_bench.reference_model.nsrm.loss import box_loss, execution_loss
from nsrmp_bench.reference_model.nsrm.model import (
    NSRM,
    Execution,
    SceneTensors,
    hard_pointers,
    piece_parses,
    split_pieces,
)
from nsrmp_bench.reference_model.tokens import PAD
from nsrmp_bench.reference_model.training import Stage

__all__ = ["build_stages", "feature_cache", "split_choice_loss"]


def _params(*mods: nn.Module) -> list[nn.Parameter]:
    return [p for m in mods for p in m.parameters()]


class _Steps:
    def __init__(self, model: NSRM, data: Encoded, cfg: NSRMConfig) -> None:
        self.model, self.data, self.cfg = model, data, cfg
        self.cache: Tensor | None = None

    def freeze_visual(self) -> None:
        """From here on the CNN is frozen: compute every training object's features once."""
        self.cache = feature_cache(self.model, self.model.features, self.data)

    def _batch(self, rows: Tensor) -> tuple[Encoded, SceneTensors, Tensor]:
        b = self.data.select(rows)
        assert b.final_boxes is not None
        feats = None if self.cache is None else self.cache[rows, : b.object_mask.shape[1]]
        return b, self.model.scene(b, feats), b.final_boxes

    def _pieces(self, b: Encoded, split: bool) -> tuple[Tensor, Tensor]:
        if not split:
            return b.tokens[:, None, :], torch.ones((len(b), 1), dtype=torch.bool)
        with torch.no_grad():
            was = self.model.training
            self.model.eval()
            cuts = split_recursively(self.model, b.tokens, self.cfg.max_steps)
            self.model.train(was)
        return split_pieces(b.tokens, cuts)

    def relaxed(self, rows: Tensor, split: bool = False) -> Tensor:
        b, scene, gold = self._batch(rows)
        pieces, pmask = self._pieces(b, split)
        r, p, t = pieces.shape
        _, parse = self.model.tag(pieces.reshape(r * p, t))
        ex = self.model.execute(scene, piece_parses(parse, parse.pointers, r, p), pmask,
                                hard=False)
        return self._loss(b, ex, pmask, gold, torch.arange(r)).mean()

    def _loss(self, b: Encoded, ex: Execution, pmask: Tensor, gold: Tensor,
              rows: Tensor) -> Tensor:
        return execution_loss(self.model.simulator, ex.world, ex.subjects, ex.bases,
                              ex.actions, pmask, b.geometry[rows], b.boxes[rows], gold[rows],
                              b.object_mask[rows], b.image_size)

    def reinforce(self, rows: Tensor, split: bool = False) -> Tensor:
        b, scene, gold = self._batch(rows)
        pieces, pmask = self._pieces(b, split)
        r, p, t = pieces.shape
        k = self.cfg.samples
        ptr_logits, parse = self.model.tag(pieces.reshape(r * p, t))
        logp_all = torch.log_softmax(ptr_logits, -1)  # (R*P, SLOTS, 1+T)
        dist = torch.distributions.Categorical(logits=ptr_logits)
        choice = torch.cat([ptr_logits.argmax(-1)[None], dist.sample((k - 1,))], 0)
        onehot = nn.functional.one_hot(choice, ptr_logits.shape[-1]).float()  # (K, R*P, S, 1+T)
        logp = logp_all[None].expand(k, -1, -1, -1).gather(-1, choice[..., None]).squeeze(-1)
        logp = (logp.sum(-1) * pmask.reshape(1, r * p)).reshape(k, r, p).sum(-1)  # (K, R)
        rows_k = torch.arange(r).repeat(k)
        scene_k = scene.repeat(rows_k)
        rep = StepParse(onehot.reshape(k * r * p, *onehot.shape[2:]),
                        parse.attribute.repeat(k, 1, 1), parse.relation.repeat(k, 1, 1),
                        parse.action.repeat(k, 1, 1))
        ex = self.model.execute(scene_k, piece_parses(rep, rep.pointers, k * r, p),
                                pmask.repeat(k, 1), hard=False)
        losses = self._loss(b, ex, pmask.repeat(k, 1), gold, rows_k).reshape(k, r)
        weight = torch.softmax(-losses.detach() / 0.5, dim=0)
        executor_loss = (weight * losses).sum(0).mean()
        advantage = (losses.mean(0, keepdim=True) - losses).detach()
        policy = -(advantage * logp).mean()
        entropy: Tensor = (dist.entropy().sum(-1) * pmask.reshape(-1)).mean()
        return executor_loss + policy - self.cfg.entropy * entropy

    def splitter(self, rows: Tensor) -> Tensor:
        b, scene, gold = self._batch(rows)

        def option_losses(idx: Tensor, pieces: Tensor, pmask: Tensor) -> Tensor:
            r, p, t = pieces.shape
            ptr, parse = self.model.tag(pieces.reshape(r * p, t))
            parses = piece_parses(parse, hard_pointers(ptr), r, p)
            ex = self.model.execute(scene.repeat(idx), parses, pmask, hard=True)
            return box_loss(ex.world, gold[idx], b.object_mask[idx], b.image_size)

        return split_choice_loss(self.model, self.model.splitter, b.tokens, option_losses)


def feature_cache(model: nn.Module, features: Callable[[Encoded], Tensor],
                  data: Encoded) -> Tensor:
    """Every episode's object features (E, N, F) by ``features``, computed once with
    ``model`` in eval mode (the CNN is frozen from then on)."""
    was = model.training
    model.eval()
    parts = []
    with torch.no_grad():
        for lo in range(0, len(data), 256):
            b = data.select(range(lo, min(lo + 256, len(data))))
            f = features(b)
            full = f.new_zeros((len(b), data.object_mask.shape[1], f.shape[-1]))
            full[:, : f.shape[1]] = f
            parts.append(full)
    model.train(was)
    return torch.cat(parts)


def split_choice_loss(model: nn.Module, splitter: nn.Module, tokens: Tensor,
                      option_losses: Callable[[Tensor, Tensor, Tensor], Tensor]) -> Tensor:
    """The splitter's loss on a batch of instructions ``tokens`` (R, T): every split point
    (and "no split") of every instruction is an option; ``option_losses(idx, pieces,
    piece_mask)`` gives each option's box loss when its pieces are executed (``idx``: the
    option's row, ``pieces`` (O, P, Tp) and ``piece_mask`` (O, P) as from
    :func:`split_pieces`), run without gradients with ``model`` in eval mode; the splitter
    learns the softmin of those losses per instruction (cross-entropy). NSRM and NMN+ train
    their splitters with it."""
    seqs = [row[row != PAD] for row in tokens]
    options: list[tuple[int, int]] = []  # (row, logit index)
    cuts: list[list[int]] = []
    for i, s in enumerate(seqs):
        options.append((i, 0))
        cuts.append([])
        for c in range(2, len(s) - 1):
            options.append((i, 1 + c))
            cuts.append([c])
    idx = torch.tensor([o[0] for o in options])
    with torch.no_grad():
        was = model.training
        model.eval()
        pieces, pmask = split_pieces(tokens[idx], cuts)
        losses = option_losses(idx, pieces, pmask)
        model.train(was)
    logits = torch.log_softmax(splitter(tokens), -1)
    chosen = logits[idx, torch.tensor([o[1] for o in options])]
    # distil the softmin of the options' losses (per instruction) into the splitter
    target = torch.zeros_like(losses)
    for i in range(len(seqs)):
        sel = idx == i
        target[sel] = torch.softmax(-losses[sel] / 0.5, 0)
    return -(target * chosen).sum() / len(seqs)


def build_stages(model: NSRM, data: Encoded, cfg: NSRMConfig) -> list[Stage]:
    """The curriculum over the training episodes ``data`` (with targets and categories)."""
    s = _Steps(model, data, cfg)
    steps, rel = data.meta["steps"], data.meta["relational"]
    single = torch.nonzero(steps == 1).flatten()
    attribute = torch.nonzero((steps == 1) & ~rel).flatten()
    every = torch.arange(len(data))
    gen = torch.Generator().manual_seed(len(data))
    subset = every[torch.randperm(len(data), generator=gen)[: cfg.splitter_examples]]
    m = model
    core = lambda: _params(m.visual, m.concepts, m.relations, m.simulator, m.tagger)  # noqa: E731
    rest = lambda: _params(m.concepts, m.relations, m.simulator, m.tagger)  # noqa: E731
    bs, lr = cfg.batch_size, cfg.lr
    return [
        Stage("attribute", cfg.epochs_attribute, attribute, core, s.relaxed, lr, bs),
        Stage("relational", cfg.epochs_relational, single, core, s.relaxed, lr, bs),
        Stage("reinforce", cfg.epochs_reinforce, single, rest, s.reinforce, lr / 2, bs,
              start=s.freeze_visual),
        Stage("splitter", cfg.epochs_splitter, subset, lambda: _params(m.splitter),
              s.splitter, lr, bs, uses_splitter=True, start=s.freeze_visual),
        Stage("multistep", cfg.epochs_multistep, every, rest,
              lambda rows: s.reinforce(rows, split=True), lr / 2, bs, uses_splitter=True,
              start=s.freeze_visual),
    ]
