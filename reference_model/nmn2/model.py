"""NMN+ v2's step model: attention in place of the program.

It shares NSRM v2's perception, splitter, action rule, training objective, token encoder
and inference (:mod:`nsrmp_bench.reference_model.program`); only the step differs. An
object is its features, its 3D centre relative to the scene's mean, and whether the
previous step moved it. The subject and the base are each chosen by attention over the
objects (the paper's NMN+, as nmn-v1 built it: word attention per head, an MLP of query
times key, heads multiplied); the action from the pooled words. There are no word
concepts, no roles and no relation operator: whatever structure it uses, it learns from
attention.

Each head's word attention is read from the encoder's contextual states, but what it
pools into the query are the attended words' own embeddings (``query_words="embedding"``):
pooling the contextual states, whose words the self-attention has mixed, the query hardly
varied with the instruction at the start, and the subject stayed at chance for 16 epochs
(the first shipped run, ``"context"``; see ``MODEL_CARD.md``).
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

from nsrmp_bench.reference_model.nmn2.config import NMN2Config
from nsrmp_bench.reference_model.program.modules import (
    Perception,
    StepModel,
    StepOutput,
    TokenEncoder,
)
from nsrmp_bench.reference_model.tokens import PAD

__all__ = ["AttentionStepModel"]


class _RoleAttention(nn.Module):
    """Attention over the objects for one role: each head pools the words with its own
    word attention (the states ``h``, or ``words`` where given), maps the pooled summary
    and the sentence mean to a query, each object to a key, and scores the object by an
    MLP of ``query * key``; the heads' scores add (their distributions multiply). Objects
    are scored independently."""

    def __init__(self, word_dim: int, object_dim: int, hidden: int, heads: int,
                 score: str = "mlp") -> None:
        super().__init__()
        if score not in ("mlp", "dot"):
            msg = f"score must be 'mlp' or 'dot', not {score!r}"
            raise ValueError(msg)
        self.dot = score == "dot"
        self.words = nn.Linear(word_dim, heads)
        self.query = nn.ModuleList(nn.Sequential(nn.Linear(2 * word_dim, hidden), nn.ReLU(),
                                                 nn.Linear(hidden, hidden))
                                   for _ in range(heads))
        self.key = nn.ModuleList(nn.Sequential(nn.Linear(object_dim, hidden), nn.ReLU(),
                                               nn.Linear(hidden, hidden))
                                 for _ in range(heads))
        self.score = nn.ModuleList(nn.Sequential(nn.Linear(hidden, hidden // 2), nn.ReLU(),
                                                 nn.Linear(hidden // 2, 1))
                                   for _ in range(0 if self.dot else heads))
        self.scale = hidden ** -0.5

    def forward(self, h: Tensor, valid: Tensor, objects: Tensor, mask: Tensor,
                words: Tensor | None = None) -> Tensor:
        att = torch.softmax(self.words(h).masked_fill(~valid[..., None], float("-inf")), 1)
        mean = (h * valid[..., None]).sum(1) / valid.sum(1, keepdim=True).clamp_min(1)
        pool = h if words is None else words
        total = torch.zeros(mask.shape)
        for k, (q, key) in enumerate(zip(self.query, self.key, strict=True)):
            summary = torch.einsum("rt,rtd->rd", att[..., k], pool)
            query = q(torch.cat([summary, mean], -1))
            both = query[:, None] * key(objects)
            total = total + (both.sum(-1) * self.scale if self.dot
                             else self.score[k](both).squeeze(-1))
        self.raw_scores = total.masked_fill(~mask, float("-inf")).detach()  # before normalising
        return torch.log_softmax(total.masked_fill(~mask, float("-inf")), -1)


class AttentionStepModel(StepModel):
    """The NMN+ v2 step model (see the module doc)."""

    def __init__(self, vocab_size: int, cfg: NMN2Config) -> None:
        super().__init__()
        self.cfg = cfg
        d = cfg.hidden
        self.perception = Perception(cfg.concept_dim, cfg.object_sizes, cfg.augment)
        self.encoder = TokenEncoder(vocab_size, d)
        obj = cfg.concept_dim + 4
        self.subject = _RoleAttention(d, obj, d, cfg.heads, cfg.score)
        self.base = _RoleAttention(d, obj, d, cfg.heads, cfg.score)
        self.action = nn.Linear(d, 3)

    def code(self, pieces: Tensor) -> Tensor:
        """Contextual word states (P, T, hidden)."""
        states: Tensor = self.encoder(pieces)
        return states

    def step(self, code: Tensor, tokens: Tensor, feats: Tensor, centres: Tensor,
             previous: Tensor, mask: Tensor) -> StepOutput:
        m = mask.float()[..., None]
        mean = (centres * m).sum(1, keepdim=True) / m.sum(1, keepdim=True).clamp_min(1.0)
        objects = torch.cat([feats, (centres - mean) / 0.1, previous[..., None]], -1)
        valid = tokens != PAD
        pooled = (code * valid[..., None]).sum(1) / valid.sum(1, keepdim=True).clamp_min(1)
        words = self.encoder.embed(tokens) if self.cfg.query_words == "embedding" else None
        return (self.subject(code, valid, objects, mask, words),
                self.base(code, valid, objects, mask, words),
                torch.log_softmax(self.action(pooled), -1))
