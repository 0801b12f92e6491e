"""NMN+'s own parts: language-guided attention over objects and the action decoder.

- :class:`RoleAttention`: for one role of a step (the subject, or the reference it is
  placed on or beside), ``heads`` attention heads over the objects. Each head pools the
  sentence's word states with its own word attention, maps the pooled sentence and that
  summary to a query, maps every object to a key, and scores the object by an MLP of
  ``query * key``; the heads' distributions are multiplied and renormalised (the
  original's "colour" and "shape" heads). Objects are scored independently: the only
  interaction between them is the softmax, as in the original. (The original scores an
  MLP of ``[query, object]``; measured from scratch, subject choice stayed at chance
  for 8 epochs of 320 episodes with it and began to learn with the product.)
- :class:`ActionDecoder`: the pooled sentence to a distribution over the 3 actions.

An object is its visual feature, its current box geometry ``[cx, cy, w, h, d]`` (which
the original lacks: ``reference/nsrm-original-model.md`` §6.3) and the previous step's
subject attention on it (where an instruction says "it").
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

from nsrmp_bench.reference_model.features import GEOMETRY
from nsrmp_bench.reference_model.nmn.config import NMNConfig
from nsrmp_bench.vocabulary import ACTIONS

__all__ = ["OBJECT_EXTRA", "ActionDecoder", "RoleAttention", "pooled"]

OBJECT_EXTRA = GEOMETRY + 1
"""What an object feature holds beyond its visual feature: geometry and the ``it`` mass."""

_NEG = -1e4


def pooled(h: Tensor, valid: Tensor) -> Tensor:
    """Mean of the word states ``h`` (R, T, D) over the real words ``valid`` (R, T)."""
    return (h * valid[..., None]).sum(1) / valid.sum(1).clamp(min=1)[:, None]


class RoleAttention(nn.Module):
    """(word states (R, T, D), valid (R, T), objects (R, N, F), mask (R, N)) -> log
    attention (R, N) over the real objects."""

    def __init__(self, word_dim: int, object_dim: int, cfg: NMNConfig) -> None:
        super().__init__()
        a = cfg.attention_hidden
        self.heads = cfg.heads
        self.words = nn.Linear(word_dim, cfg.heads)
        self.query = nn.ModuleList(
            nn.Sequential(nn.Linear(2 * word_dim, a), nn.ReLU(), nn.Linear(a, a))
            for _ in range(cfg.heads)
        )
        self.key = nn.ModuleList(
            nn.Sequential(nn.Linear(object_dim, a), nn.ReLU(), nn.Linear(a, a))
            for _ in range(cfg.heads)
        )
        self.score = nn.ModuleList(
            nn.Sequential(nn.Linear(a, a // 2), nn.ReLU(), nn.Linear(a // 2, 1))
            for _ in range(cfg.heads)
        )

    def forward(self, h: Tensor, valid: Tensor, objects: Tensor, mask: Tensor) -> Tensor:
        mean = pooled(h, valid)
        w = torch.softmax(self.words(h).masked_fill(~valid[..., None], _NEG), dim=1)
        total = objects.new_zeros(objects.shape[:2])
        for k in range(self.heads):
            summary = (w[..., k : k + 1] * h).sum(1)
            q = self.query[k](torch.cat([mean, summary], -1))
            x = q[:, None, :] * self.key[k](objects)
            s = self.score[k](x).squeeze(-1).masked_fill(~mask, _NEG)
            total = total + torch.log_softmax(s, -1)
        out: Tensor = torch.log_softmax(total.masked_fill(~mask, _NEG), -1)
        return out


class ActionDecoder(nn.Module):
    """Pooled sentence (R, D) -> action logits (R, 3)."""

    def __init__(self, word_dim: int, cfg: NMNConfig) -> None:
        super().__init__()
        a = cfg.attention_hidden
        self.net = nn.Sequential(nn.Linear(word_dim, a), nn.ReLU(), nn.Linear(a, len(ACTIONS)))

    def forward(self, sentence: Tensor) -> Tensor:
        out: Tensor = self.net(sentence)
        return out
