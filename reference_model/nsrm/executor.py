"""The differentiable executor of NSRM's programs, vectorised over rows and candidates.

A step's program is given by a pointer per parameter slot (:data:`SLOTS`) to a word of
the sub-instruction, or to nothing (column 0):
``move[A](filter(S1, filter(S2, relate(SR, unique(filter(SA1, filter(SA2, scene))))))``,
and the same for the base; a slot pointing to nothing drops its node. A word's meaning is
a distribution over the concepts (and ``it``: the previous step's subject), so the
program's concepts are those of the words pointed to. Pointers are weights: one-hot for
a discrete program (sampled, or the argmax at inference), probabilities for the relaxed
program the first stages train on.

Sets of objects are log-probabilities over objects (a filter adds the log-probability of
its concept: the product AND), ``unique`` is a softmax (training) or an argmax
(inference), and ``move`` replaces the subject's row of the world by the action
simulator's output: ``world * (1 - m) + new * m``.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

from nsrmp_bench.reference_model.nsrm.modules import SLOTS, ActionSimulator

__all__ = ["StepParse", "execute_step"]

_K = {s: i for i, s in enumerate(SLOTS)}
_NEG = -1e4
_SHARP = 2.0


class StepParse:
    """One sub-instruction's parse for R rows: pointer weights (R, SLOTS, 1 + T) and the
    words' meaning distributions (attribute-or-it (R, T, 11), relation (R, T, 4), action
    (R, T, 3))."""

    def __init__(self, pointers: Tensor, attribute: Tensor, relation: Tensor, action: Tensor):
        self.pointers, self.attribute = pointers, attribute
        self.relation, self.action = relation, action

    def words(self, slot: str) -> Tensor:
        """Weights (R, T) of the words slot ``slot`` points to."""
        return self.pointers[:, _K[slot], 1:]


def _unique(score: Tensor, mask: Tensor, hard: bool) -> Tensor:
    score = score.masked_fill(~mask, _NEG)
    if hard:
        return F.one_hot(score.argmax(-1), score.shape[-1]).to(score.dtype)
    return torch.softmax(score, dim=-1)


def _filter(parse: StepParse, tok: Tensor, *slots: str) -> Tensor:
    return _SHARP * sum(  # type: ignore[return-value]
        torch.einsum("rt,rtn->rn", parse.words(s), tok) for s in slots
    )


def _reference(parse: StepParse, tok: Tensor, rel_logp: Tensor, mask: Tensor, side: str,
               hard: bool) -> Tensor:
    score = _filter(parse, tok, f"{side}1", f"{side}2")
    anchor = _unique(_filter(parse, tok, f"{side}A1", f"{side}A2"), mask, hard)  # (R, N_a)
    rel_t = torch.einsum("rtk,rjak->rtja", parse.relation, rel_logp)
    rel_term = torch.logsumexp(rel_t + torch.log(anchor + 1e-9)[:, None, None, :], dim=-1)
    score = score + _SHARP * torch.einsum("rt,rtn->rn", parse.words(f"{side}R"), rel_term)
    return _unique(score, mask, hard)


def execute_step(parse: StepParse, attr_logp: Tensor, rel_logp: Tensor, world: Tensor,
                 mask: Tensor, prev_subject: Tensor | None, sim: ActionSimulator,
                 hard: bool) -> tuple[Tensor, Tensor, Tensor, Tensor]:
    """Run one step on ``world`` (R, N, 5).

    ``attr_logp`` (R, N, 10) and ``rel_logp`` (R, N, N, 4) are the log-probabilities of the
    attribute and relation concepts; ``mask`` (R, N) the real objects. Returns the new
    world, the subject and base distributions (R, N) and the action distribution (R, 3).
    """
    if prev_subject is None:
        it = torch.zeros_like(attr_logp[..., :1])
    else:
        it = torch.log(prev_subject + 1e-6)[..., None]
    tok = torch.einsum("rtc,rnc->rtn", parse.attribute, torch.cat([attr_logp, it], -1))
    subject = _reference(parse, tok, rel_logp, mask, "S", hard)
    base = _reference(parse, tok, rel_logp, mask, "B", hard)
    act_score = torch.einsum("rt,rta->ra", parse.words("A"), torch.log(parse.action + 1e-9))
    action = (F.one_hot(act_score.argmax(-1), act_score.shape[-1]).to(act_score.dtype)
              if hard else torch.softmax(act_score, dim=-1))
    subj_loc = torch.einsum("rn,rnd->rd", subject, world)
    base_loc = torch.einsum("rn,rnd->rd", base, world)
    new = sim(subj_loc, base_loc, action)
    m = subject[..., None]
    return world * (1 - m) + new[:, None, :] * m, subject, base, action
