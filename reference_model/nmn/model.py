"""NMN+: the paper's attention baseline, wired from NSRM's shared parts and its own.

Shared with NSRM (its modules, imported): the visual extractor (crop CNN), the language
encoder (BiGRU over words), the splitter and the action simulator. Its own
(:mod:`.modules`): attention over the objects for the subject and the reference of each
step, and the action decoder. :meth:`NMN.execute` runs, for R rows, up to P
sub-instructions in order on the initial world; :func:`infer` is the hard (argmax)
inference with recursive splitting.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nsrmp_bench.reference_model.encoded import Encoded
from nsrmp_bench.reference_model.nmn.config import NMNConfig
from nsrmp_bench.reference_model.nmn.modules import (
    OBJECT_EXTRA,
    ActionDecoder,
    RoleAttention,
    pooled,
)
from nsrmp_bench.reference_model.nsrm.inference import Inferred, split_recursively
from nsrmp_bench.reference_model.nsrm.model import Execution, object_features, split_pieces
from nsrmp_bench.reference_model.nsrm.modules import (
    ActionSimulator,
    Splitter,
    VisualExtractor,
    WordEncoder,
)
from nsrmp_bench.reference_model.tokens import PAD

__all__ = ["NMN", "infer"]

_GEOMETRY_SCALE = torch.tensor([4.0, 4.0, 10.0, 10.0, 2.0])
"""Scales ``[cx, cy, w, h, d]`` to about unit range for the attention MLPs."""


class NMN(nn.Module):
    """The NMN+ baseline (object-centric, attention over objects; no program)."""

    def __init__(self, vocab_size: int, cfg: NMNConfig) -> None:
        super().__init__()
        self.cfg = cfg
        shared = cfg.shared()
        self.visual = VisualExtractor(shared)
        self.encoder = WordEncoder(vocab_size, shared)
        self.splitter = Splitter(vocab_size, shared)
        self.simulator = ActionSimulator(shared)
        d, obj = 2 * cfg.hidden, self.visual.out_dim + OBJECT_EXTRA
        self.subject = RoleAttention(d, obj, cfg)
        self.base = RoleAttention(d, obj, cfg)
        self.action = ActionDecoder(d, cfg)

    def features(self, enc: Encoded) -> Tensor:
        """Visual features (B, N, F) of the real objects (zeros for padding)."""
        return object_features(self.visual, enc)

    def execute(self, feats: Tensor, world: Tensor, mask: Tensor, pieces: Tensor,
                piece_mask: Tensor, hard: bool) -> Execution:
        """Run the sub-instructions ``pieces`` (R, P, T) in order on ``world`` (R, N, 5).

        ``feats`` (R, N, F) are the objects' visual features, ``mask`` (R, N) the real
        objects, ``piece_mask`` (R, P) which rows have a p-th step (a row without one keeps
        its world). Attention is a softmax in training and an argmax (``hard``) otherwise;
        the subject's row of the world is replaced by the action simulator's output.
        """
        r, p, t = pieces.shape
        flat = pieces.reshape(r * p, t)
        h = self.encoder(flat).reshape(r, p, t, -1)
        valid = (flat != PAD).reshape(r, p, t)
        prev = torch.zeros_like(world[..., 0])
        subjects, bases, actions, worlds = [], [], [], []
        for k in range(p):
            hk, vk = h[:, k], valid[:, k]
            objects = torch.cat([feats, world * _GEOMETRY_SCALE, prev[..., None]], -1)
            subj = _choose(self.subject(hk, vk, objects, mask), hard)
            base = _choose(self.base(hk, vk, objects, mask), hard)
            act = _choose(torch.log_softmax(self.action(pooled(hk, vk)), -1), hard)
            new = self.simulator(torch.einsum("rn,rnd->rd", subj, world),
                                 torch.einsum("rn,rnd->rd", base, world), act)
            m = subj[..., None]
            on = piece_mask[:, k, None]
            world = torch.where(on[..., None], world * (1 - m) + new[:, None, :] * m, world)
            prev = torch.where(on, subj, prev)
            subjects.append(subj)
            bases.append(base)
            actions.append(act)
            worlds.append(world)
        return Execution(world, torch.stack(subjects, 1), torch.stack(bases, 1),
                         torch.stack(actions, 1), torch.stack(worlds, 1))


def _choose(logp: Tensor, hard: bool) -> Tensor:
    if hard:
        return F.one_hot(logp.argmax(-1), logp.shape[-1]).to(logp.dtype)
    return logp.exp()


@torch.no_grad()
def infer(model: NMN, enc: Encoded, batch_size: int = 128, split: bool = True) -> Inferred:
    """Steps (action, subject, base) and per-step worlds of every episode of ``enc`` (model
    in eval mode). ``split=False`` reads every instruction as one step (validation before
    the splitter has been trained)."""
    model.eval()
    steps: list[list[tuple[int, int, int]]] = []
    worlds: list[Tensor] = []
    for lo in range(0, len(enc), batch_size):
        b = enc.select(range(lo, min(lo + batch_size, len(enc))))
        cuts = (split_recursively(model, b.tokens, model.cfg.max_steps) if split
                else [[] for _ in range(len(b))])
        pieces, pmask = split_pieces(b.tokens, cuts)
        ex = model.execute(model.features(b), b.geometry, b.object_mask, pieces, pmask,
                           hard=True)
        n_obj = b.object_mask.sum(1).tolist()
        for i in range(len(b)):
            n_steps = int(pmask[i].sum())
            steps.append([(int(ex.actions[i, k].argmax()), int(ex.subjects[i, k].argmax()),
                           int(ex.bases[i, k].argmax())) for k in range(n_steps)])
            worlds.append(ex.step_worlds[i, :n_steps, : n_obj[i]].clone())
    return Inferred(steps, worlds)
