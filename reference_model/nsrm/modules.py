"""NSRM's learned parts: concept grounding, relations, the action simulator, the parser.

- :class:`ConceptGrounder` (visual reasoner): NSCL-style concept embeddings for the 7
  colours and 3 shapes; an object's logit for a concept is the cosine of its feature,
  mapped by the concept's attribute operator (colour or shape), with the concept's
  embedding, scaled as in the original (margin 0.85, tau 0.25).
- :class:`RelationScorer`: logits of "j is R of a" for the 4 relations from the pair's
  geometry (box centres, sizes and depths), in place of the original's union-box features.
- :class:`ActionSimulator`: from the action (a distribution over top/left/right) and the
  subject's and reference's locations to the subject's new location ``[cx, cy, w, h, d]``.
- :class:`Tagger` (language reasoner): a BiGRU over a sub-instruction and a pointer per
  parameter slot of the step's program (:data:`SLOTS`), plus which concept each word names.
- :class:`Splitter`: where an instruction splits into two sub-instructions, or not at all.
"""

from __future__ import annotations

from typing import cast

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nsrmp_bench.reference_model.features import GEOMETRY, CropEncoder
from nsrmp_bench.reference_model.nsrm.config import NSRMConfig
from nsrmp_bench.reference_model.tokens import PAD
from nsrmp_bench.vocabulary import ACTIONS, COLOURS, RELATIONS, SHAPES

__all__ = [
    "ATTRIBUTES",
    "IT",
    "SLOTS",
    "ActionSimulator",
    "ConceptGrounder",
    "RelationScorer",
    "Splitter",
    "Tagger",
    "VisualExtractor",
    "WordEncoder",
]

ATTRIBUTES = (*COLOURS, *SHAPES)
"""The attribute concepts (the DSL's inventory); which words name them is learned."""

SLOTS = ("S1", "S2", "SA1", "SA2", "SR", "B1", "B2", "BA1", "BA2", "BR", "A")
"""The program's parameter slots for one step, each a pointer to a word of the
sub-instruction or to nothing: two attribute words of the subject, two of its anchor and
its relation word (``move(filter(S1, filter(S2, relate(SR, filter(SA1, filter(SA2,
scene)))))``), the same for the base, and the action word. A slot pointing to nothing
drops its node. A word whose meaning is ``it`` refers to the previous step's subject (the
DSL has no node for it: see the model card)."""

IT = len(ATTRIBUTES)
"""Index of the meaning ``it`` among a word's attribute meanings (after the 10 concepts)."""

N_SLOTS = len(SLOTS)


class ConceptGrounder(nn.Module):
    """Object features (..., F) -> attribute logits (..., len(ATTRIBUTES))."""

    def __init__(self, in_dim: int, cfg: NSRMConfig) -> None:
        super().__init__()
        self.ops = nn.ModuleList(
            nn.Sequential(nn.Linear(in_dim, 64), nn.ReLU(), nn.Linear(64, cfg.concept_dim))
            for _ in range(2)
        )
        self.embeddings = nn.Parameter(torch.randn(len(ATTRIBUTES), cfg.concept_dim) * 0.5)
        self.margin, self.tau = cfg.margin, cfg.tau
        self.register_buffer(
            "space", torch.tensor([0] * len(COLOURS) + [1] * len(SHAPES)), persistent=False
        )

    def forward(self, feats: Tensor) -> Tensor:
        emb = F.normalize(self.embeddings, dim=-1)
        out = []
        for k, op in enumerate(self.ops):
            z = F.normalize(op(feats), dim=-1)
            out.append(z @ emb[self.space == k].T)
        cos = torch.cat(out, dim=-1)
        return (cos - 1 + self.margin) / self.margin / self.tau


class RelationScorer(nn.Module):
    """Geometry (B, N, 5) -> logits (B, N_j, N_a, 4): "j is R of a"; j == a is never."""

    def __init__(self, cfg: NSRMConfig) -> None:
        super().__init__()
        self.net = nn.Sequential(
            nn.Linear(3 * GEOMETRY, cfg.relation_hidden), nn.ReLU(),
            nn.Linear(cfg.relation_hidden, cfg.relation_hidden), nn.ReLU(),
            nn.Linear(cfg.relation_hidden, len(RELATIONS)),
        )

    def forward(self, geometry: Tensor) -> Tensor:
        n = geometry.shape[1]
        gj = geometry[:, :, None, :].expand(-1, n, n, -1)
        ga = geometry[:, None, :, :].expand(-1, n, n, -1)
        out: Tensor = self.net(torch.cat([(gj - ga) * 10.0, gj, ga], dim=-1))
        eye = torch.eye(n, dtype=torch.bool, device=geometry.device)[None, :, :, None]
        return out.masked_fill(eye, -10.0)


class ActionSimulator(nn.Module):
    """(subject (R, 5), base (R, 5), action probs (R, 3)) -> subject's new location (R, 5).

    Locations are ``[cx, cy, w, h, d]`` (image-normalised centre and size, depth in
    metres). The output starts from the DSL's action geometry, seen from the camera:
    ``top`` puts the subject's centre above the base's (by half the base's height),
    ``left``/``right`` beside it along image x (by the two half-widths and a gap), at the
    base's depth and the subject's size; the network learns the corrections (perspective,
    stacks, sizes). This prior also fixes which action index means which action.
    """

    def __init__(self, cfg: NSRMConfig) -> None:
        super().__init__()
        self.net = nn.Sequential(
            nn.Linear(2 * GEOMETRY + len(ACTIONS), cfg.action_hidden), nn.ReLU(),
            nn.Linear(cfg.action_hidden, cfg.action_hidden), nn.ReLU(),
            nn.Linear(cfg.action_hidden, GEOMETRY),
        )
        last = cast(nn.Linear, self.net[-1])
        nn.init.zeros_(last.weight)
        nn.init.zeros_(last.bias)
        side = [0.0 if a == "top" else (-1.0 if a == "left" else 1.0) for a in ACTIONS]
        self.register_buffer("side", torch.tensor(side), persistent=False)
        self.register_buffer("top", torch.tensor([float(a == "top") for a in ACTIONS]),
                             persistent=False)

    side: Tensor
    top: Tensor

    def forward(self, subject: Tensor, base: Tensor, action: Tensor) -> Tensor:
        x = torch.cat([subject * _SCALE, base * _SCALE, action], dim=-1)
        o = self.net(x)
        side = (action * self.side).sum(-1, keepdim=True)
        top = (action * self.top).sum(-1, keepdim=True)
        prior_x = side * (subject[..., 2:3] + base[..., 2:3]) * 0.6
        prior_y = -top * base[..., 3:4] * 0.5
        centre = base[..., :2] + torch.cat([prior_x, prior_y], -1) + o[..., :2] * 0.1
        size = subject[..., 2:4] * torch.exp(o[..., 2:4].clamp(-2, 2) * 0.2)
        depth = base[..., 4:5] + o[..., 4:5] * 0.1
        return torch.cat([centre, size, depth], dim=-1)


_SCALE = torch.tensor([4.0, 4.0, 10.0, 10.0, 2.0])


class WordEncoder(nn.Module):
    """Tokens (R, T) -> per-word states (R, T, 2 * hidden): a 2-layer BiGRU with word
    dropout in training. NSRM's parser and splitter each have one (NMN+ reuses it)."""

    def __init__(self, vocab: int, cfg: NSRMConfig) -> None:
        super().__init__()
        self.embed = nn.Embedding(vocab, cfg.word_dim, padding_idx=PAD)
        self.gru = nn.GRU(cfg.word_dim, cfg.hidden, num_layers=2, batch_first=True,
                          bidirectional=True, dropout=0.1)
        self.word_dropout = cfg.word_dropout

    def forward(self, tokens: Tensor) -> Tensor:
        if self.training and self.word_dropout > 0:
            drop = (torch.rand(tokens.shape) < self.word_dropout) & (tokens != PAD)
            tokens = tokens.masked_fill(drop, 1)
        lengths = (tokens != PAD).sum(1).clamp(min=1)
        packed = nn.utils.rnn.pack_padded_sequence(
            self.embed(tokens), lengths.cpu(), batch_first=True, enforce_sorted=False
        )
        out, _ = self.gru(packed)
        h, _ = nn.utils.rnn.pad_packed_sequence(out, batch_first=True,
                                                total_length=tokens.shape[1])
        out_h: Tensor = h
        return out_h


class Tagger(nn.Module):
    """Tokens (R, T) -> slot pointer logits (R, SLOTS, 1 + T) (index 0: nothing), and per
    word its attribute-or-``it`` (R, T, 11), relation (R, T, 4) and action (R, T, 3)
    meaning logits. Padding can never be pointed to."""

    def __init__(self, vocab: int, cfg: NSRMConfig) -> None:
        super().__init__()
        self.encoder = WordEncoder(vocab, cfg)
        d = 2 * cfg.hidden
        self.keys = nn.Linear(d, d)
        self.queries = nn.Parameter(torch.randn(N_SLOTS, d) * 0.3)
        self.context = nn.Linear(d, N_SLOTS * d)
        self.none = nn.Linear(d, N_SLOTS)
        self.attribute = nn.Linear(d, len(ATTRIBUTES) + 1)
        self.relation = nn.Linear(d, len(RELATIONS))
        self.action = nn.Linear(d, len(ACTIONS))
        with torch.no_grad():
            # peaked word -> concept guesses break the symmetry between concepts at once
            self.attribute.weight.mul_(4.0)
        self.scale = d ** -0.5

    def forward(self, tokens: Tensor) -> tuple[Tensor, Tensor, Tensor, Tensor]:
        h = self.encoder(tokens)
        valid = tokens != PAD
        pooled = (h * valid[..., None]).sum(1) / valid.sum(1).clamp(min=1)[:, None]
        q = self.queries[None] + self.context(pooled).reshape(len(h), N_SLOTS, -1)
        ptr = torch.einsum("rkd,rtd->rkt", q, self.keys(h)) * self.scale
        ptr = ptr.masked_fill(~valid[:, None, :], -1e4)
        logits = torch.cat([self.none(pooled)[..., None], ptr], dim=-1)
        return logits, self.attribute(h), self.relation(h), self.action(h)


class Splitter(nn.Module):
    """Tokens (R, T) -> logits (R, 1 + T): index 0 is "no split", index 1 + t a split
    before token t, into the pieces ``tokens[:t]`` and ``tokens[t:]`` (2 <= t <= len - 2)."""

    def __init__(self, vocab: int, cfg: NSRMConfig) -> None:
        super().__init__()
        self.encoder = WordEncoder(vocab, cfg)
        self.score = nn.Sequential(nn.Linear(2 * cfg.hidden, 64), nn.ReLU(), nn.Linear(64, 1))
        self.none = nn.Sequential(nn.Linear(2 * cfg.hidden, 64), nn.ReLU(), nn.Linear(64, 1))

    def forward(self, tokens: Tensor) -> Tensor:
        h = self.encoder(tokens)
        valid = tokens != PAD
        s = self.score(h).squeeze(-1)
        lengths = valid.sum(1)
        # a split before t needs at least 2 tokens on each side
        pos = torch.arange(tokens.shape[1])[None, :]
        ok = (pos >= 2) & (pos <= lengths[:, None] - 2)
        s = s.masked_fill(~ok, -1e4)
        pooled = (h * valid[..., None]).sum(1) / lengths.clamp(min=1)[:, None]
        none = self.none(pooled)
        return torch.cat([none, s], dim=1)


class VisualExtractor(nn.Module):
    """Crops (M, 3, C, C) -> object features (M, F)."""

    def __init__(self, cfg: NSRMConfig) -> None:
        super().__init__()
        self.cnn = CropEncoder(cfg.visual_dim)
        self.out_dim = self.cnn.out_dim

    def forward(self, crops: Tensor) -> Tensor:
        out: Tensor = self.cnn(crops)
        return out
