"""NSRM v2's step model: concepts tied to words (D2) and a role parser with structure (D3).

**Words are concepts.** Each vocabulary word carries its own meaning in every kind: an
attribute concept (a vector scored against an object's features, and a bias), an
affinity for the object the previous step moved (what ``it`` comes to mean), a relation
(weights over the world offset between two objects: left/right, behind/front, above) and
action logits (top, left, right). Which words name concepts, and of which kind, is what
training decides; synonyms learn separate concepts. There is no slot inventory to permute.

**The parser labels roles.** A token encoder (convolutions and self-attention) reads the
piece and gives every token a distribution over roles: nothing, or for each of the subject
and the base its head, its relation or its relation's anchor; and a probability that it
speaks of the action. A reference's
head filter is the
role-weighted conjunction of its head words' concepts (each word's concept score through
a "leaky" log sigmoid, :meth:`ConceptStepModel.word_filter`); a relational reference scores each
object by the relation to an anchor chosen by the anchor words' conjunction. With
``ordered_roles`` (the shipped setting) a reference reads in the grammar's order, head
words before its relation word and anchor words after it: a word's head weight is scaled
by the probability that no relation word of its reference came before it (the most
probable one so far), its anchor weight by the probability that one did; with
``relation_after_head`` (shipped) a word is a reference's relation only as far as that
reference's head began before it, so the subject's relation word, earlier in the piece,
does not silence the base's head words; with ``contiguous_references`` a reference is one
phrase, and no word after the other reference's head began (after this one's had) is its
relation or its anchor, so the base's relation word cannot become the subject's. Relations
are read on the centres the step is given: the world as the previous steps left it (D5).
The role marginals are expectations of a linear score, so training and inference read
the same parse (the argmax role of each token at inference is not needed: the score is
linear in the roles).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nsrmp_bench.reference_model.nsrm2.config import NSRM2Config
from nsrmp_bench.reference_model.program.modules import (
    Perception,
    StepModel,
    StepOutput,
    TokenEncoder,
)
from nsrmp_bench.reference_model.tokens import PAD

__all__ = ["ROLES", "ConceptStepModel"]

ROLES = ("none", "action", "subject", "subject-relation", "subject-anchor", "base",
         "base-relation", "base-anchor")
_ACTION = 1
_REFS = ((2, 3, 4), (5, 6, 7))  # (head, relation, anchor) roles of subject and base
_OFFSET_SCALE = 0.05  # metres: relation weights read offsets in object sizes


class ConceptStepModel(StepModel):
    """The NSRM v2 step model (see the module doc)."""

    def __init__(self, vocab_size: int, cfg: NSRM2Config) -> None:
        super().__init__()
        self.cfg = cfg
        d = cfg.concept_dim
        self.perception = Perception(d, cfg.object_sizes, cfg.augment)
        self.concept = nn.Embedding(vocab_size, d)
        self.concept_bias = nn.Embedding(vocab_size, 1)
        self.previous = nn.Embedding(vocab_size, 1)
        self.relation = nn.Embedding(vocab_size, 3)
        self.relation_bias = nn.Embedding(vocab_size, 1)
        self.action = nn.Embedding(vocab_size, 3)
        for emb in (self.previous, self.relation, self.relation_bias, self.action):
            nn.init.zeros_(emb.weight)
        nn.init.zeros_(self.concept.weight)  # no word means anything yet: no noise
        nn.init.zeros_(self.concept_bias.weight)
        self.encoder = TokenEncoder(vocab_size, cfg.hidden)
        self.roles = nn.Linear(cfg.hidden, len(ROLES))

    def warmup_parameters(self) -> list[nn.Parameter]:
        """Perception and the words' concepts, with the parser's roles held uniform: with
        no concept learnt yet, a free parser collapses onto whatever role costs least."""
        parser = {id(p) for p in (*self.encoder.parameters(), *self.roles.parameters())}
        return [p for p in self.parameters() if id(p) not in parser]

    def code(self, pieces: Tensor) -> Tensor:
        """Role probabilities (P, T, ROLES); padding has none.

        The reference roles (and "none") are one distribution per token; whether a token
        speaks of the action is a separate probability, so that the action, which is easy
        to learn, cannot take every word from the references while they are learnt."""
        logits = self.roles(self.encoder(pieces))
        refs = torch.softmax(torch.cat([logits[..., :_ACTION], logits[..., _ACTION + 1 :]],
                                       -1), -1)
        # a word inside a reference is not an action word: the action weight is the
        # action probability times the probability of belonging to no reference
        action = torch.sigmoid(logits[..., _ACTION : _ACTION + 1]) * refs[..., :1]
        probs = torch.cat([refs[..., :_ACTION], action, refs[..., _ACTION:]], -1)
        return probs * (pieces != PAD)[..., None]

    def word_filter(self, tokens: Tensor, feats: Tensor,
                    previous: Tensor | None = None) -> Tensor:
        """(R, T, N): each word's term for each object in a reference's conjunction, from
        its concept score x = concept . features + bias through ``filter_link``: log
        sigmoid(x) (a log-probability), x, or "leaky" log sigmoid(x) + x / 10. Log sigmoid
        alone saturates: a word that came to score an object high (``cube`` on dice,
        learnt before the crops told the two apart) gets almost no gradient to lower it,
        so it never unlearns it; the leak keeps a tenth of the gradient everywhere.

        The word's affinity for the object the previous step moved (``previous`` (R, N))
        is added after the link (``previous_after_link``, the default): inside it, as
        checkpoints from before read it, the part that lands where the link saturates is
        lost, and "it" preferred the previous subject by a fraction of its affinity."""
        logit: Tensor = torch.einsum("rtd,rnd->rtn", self.concept(tokens), feats)
        logit = logit + self.concept_bias(tokens)
        affinity = None if previous is None else self.previous(tokens) * previous[:, None]
        if affinity is not None and not self.cfg.previous_after_link:
            logit, affinity = logit + affinity, None
        out = _link(logit, self.cfg.filter_link)
        return out if affinity is None else out + affinity

    def step(self, code: Tensor, tokens: Tensor, feats: Tensor, centres: Tensor,
             previous: Tensor, mask: Tensor) -> StepOutput:
        log_filter = self.word_filter(tokens, feats, previous)
        offsets = (centres[:, :, None] - centres[:, None]) / _OFFSET_SCALE  # (R, N, N, 3)
        eye = torch.eye(mask.shape[1], dtype=torch.bool, device=mask.device)
        others = mask[:, None, :] & ~eye[None]
        out = []
        raw = []
        for k, (head, rel, anchor) in enumerate(_REFS):
            head_w, anchor_w, rel_w = code[..., head], code[..., anchor], code[..., rel]
            if self.cfg.contiguous_references:
                # a reference is one phrase: once the other reference's head began after
                # this one's had (the most probable such word so far), no later word is
                # this one's relation or anchor
                # (_before(head_w) is computed here and again below on purpose: one
                # shared node sums its two gradients in another order, which changes
                # training's floats; the shipped checkpoint is retrained byte for byte
                # only as it is, and the tiny run of tests/models/test_nsrm2.py misses
                # its loss bound with the shared node)
                other = code[..., _REFS[1 - k][0]]
                inside = 1.0 - _before(other * _before(head_w))
                rel_w, anchor_w = rel_w * inside, anchor_w * inside
            if self.cfg.relation_after_head:
                # a word is the reference's relation only as far as the reference's head
                # began before it (the most probable head word so far): the other
                # reference's relation word, earlier in the piece, is not this one's
                rel_w = rel_w * _before(head_w)
            if self.cfg.ordered_roles:
                # a reference reads head, then relation, then anchor: a word is its head
                # as far as no relation word came before it, its anchor as far as one did
                # (the most probable relation word so far: a sum of the warm-up's uniform
                # roles would reach 1 within a few tokens and silence every later word)
                before = _before(rel_w)
                head_w, anchor_w = head_w * (1.0 - before), anchor_w * before
            score = torch.einsum("rt,rtn->rn", head_w, log_filter)
            anchor_lp = _masked_log_softmax(
                torch.einsum("rt,rtn->rn", anchor_w, log_filter), mask)
            weights = torch.einsum("rt,rtk->rk", rel_w, self.relation(tokens))
            bias = torch.einsum("rt,rtk->rk", rel_w, self.relation_bias(tokens))
            pair = F.logsigmoid(torch.einsum("rijk,rk->rij", offsets, weights) + bias[..., None])
            pair = pair + anchor_lp[:, None, :]
            related = torch.logsumexp(pair.masked_fill(~others, float("-inf")), -1)
            score = score + torch.nan_to_num(related, neginf=0.0)
            raw.append(score.masked_fill(~mask, float("-inf")))
            out.append(_masked_log_softmax(score, mask))
        # each reference's scores before normalising over the objects: how well the best
        # object fits the words at all (a reader's confidence; nothing trains on it)
        self.raw_scores = (raw[0].detach(), raw[1].detach())
        action = torch.log_softmax(
            torch.einsum("rt,rtk->rk", code[..., _ACTION], self.action(tokens)), -1)
        return out[0], out[1], action


def _link(x: Tensor, link: str) -> Tensor:
    """A word's concept scores ``x`` through ``filter_link`` (see
    :meth:`ConceptStepModel.word_filter`)."""
    if link == "linear":
        return x
    out = F.logsigmoid(x)
    return out + 0.1 * x if link == "leaky" else out


def _before(weights: Tensor) -> Tensor:
    """(R, T): the largest of ``weights`` over the tokens before each token (0 at the
    first)."""
    return F.pad(torch.cummax(weights, -1).values[..., :-1], (1, 0))


def _masked_log_softmax(x: Tensor, mask: Tensor) -> Tensor:
    return torch.log_softmax(x.masked_fill(~mask, float("-inf")), -1)
