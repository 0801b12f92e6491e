"""The training objective of any step model: the likelihood of what the boxes show.

An episode's instruction is either one step (no cut) or two steps cut at some token. Under
an option, the likelihood of an episode sums, over the programs consistent with its final
boxes (:mod:`.consistent`), the probability of every step of the program, each step read
on the world its previous steps left (D5) with the previous subject marked. The programs
are enumerated: the sum is exact.

Stages (the splitter learns from a reliable signal, D4):

- ``warmup`` and ``single``: the episodes where exactly one box changed, as one step
  (:func:`single_loss`);
- ``joint``: every episode (:func:`joint_loss`). A teacher (:func:`teacher_cuts`, no
  gradient) scores the options "one step" and the cuts whose prefix best explains a
  consistent first step; its posterior over them is the splitter's soft target, and the
  step model learns the marginal likelihood over the teacher's best options.

The action is always a distribution over the three actions, scored by the same
log-probability in training and read by its argmax at inference (D1).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
from torch import Tensor

from nsrmp_bench.reference_model.program.data import ProgramData
from nsrmp_bench.reference_model.program.modules import Splitter, StepModel, pad_tokens

__all__ = ["EpisodeBatch", "episode_batch", "fit_threshold", "joined_instructions", "joint_loss",
           "option_scores", "pad_tokens", "single_loss", "teacher_cuts"]

THRESHOLD_TOLERANCE = 0.01
"""The splitter's threshold is the lowest that counts within this fraction of the most
training episodes right (:func:`fit_calibration`)."""


class EpisodeBatch:
    """Episodes ``rows`` of ``data`` as tensors: crops, mask, centres (float32) and the
    objects' estimated sizes (width, height in metres)."""

    def __init__(self, data: ProgramData, rows: Sequence[int]) -> None:
        sub = data.enc.select(list(rows))
        self.rows = list(rows)
        self.crops = sub.crops
        self.mask = sub.object_mask
        n = self.mask.shape[1]
        self.centres = torch.zeros((len(rows), n, 3))
        self.sizes = torch.zeros((len(rows), n, 2))
        for i, r in enumerate(rows):
            s = data.states[r]
            self.centres[i, : len(s)] = torch.from_numpy(s.centres).float()
            self.sizes[i, : len(s)] = torch.from_numpy(np.stack([s.sizes, s.heights], 1)).float()
        self.tokens = [data.tokens[r] for r in rows]


def episode_batch(data: ProgramData, rows: Sequence[int]) -> EpisodeBatch:
    """See :class:`EpisodeBatch`."""
    return EpisodeBatch(data, rows)


def _score(out: tuple[Tensor, Tensor, Tensor], row: Tensor, programs: Tensor) -> Tensor:
    """log P(subject) + log P(base) + log P(action) of ``programs`` (M, 3) at ``row`` (M,)."""
    s, b, a = out
    return s[row, programs[:, 0]] + b[row, programs[:, 1]] + a[row, programs[:, 2]]


def _segment_logsumexp(values: Tensor, segment: Tensor, n: int) -> Tensor:
    """logsumexp of ``values`` per segment id (0..n-1); -inf for an empty segment."""
    out = torch.full((n,), float("-inf"), dtype=values.dtype)
    if len(values) == 0:
        return out
    top = torch.full((n,), float("-inf"), dtype=values.dtype).scatter_reduce(
        0, segment, values.detach(), reduce="amax")
    safe = torch.where(torch.isfinite(top), top, torch.zeros_like(top))
    sums = torch.zeros((n,), dtype=values.dtype).index_add(
        0, segment, torch.exp(values - safe[segment]))
    return torch.where(sums > 0, torch.log(sums.clamp_min(1e-30)) + safe, out)


def single_loss(model: StepModel, data: ProgramData, rows: Sequence[int]) -> Tensor:
    """Minus the mean log-probability of each episode's consistent one-step programs, the
    whole instruction read as one step."""
    assert data.consistent is not None
    batch = EpisodeBatch(data, rows)
    tokens = pad_tokens(batch.tokens)
    feats = model.features(batch.crops, batch.mask, batch.sizes)
    out = model.step(model.code(tokens), tokens, feats, batch.centres,
                     torch.zeros(batch.mask.shape), batch.mask)
    progs, seg = [], []
    for i, r in enumerate(rows):
        one = torch.from_numpy(data.consistent[r].one)
        progs.append(one)
        seg.append(torch.full((len(one),), i, dtype=torch.long))
    p = torch.cat(progs) if progs else torch.zeros((0, 3), dtype=torch.long)
    s = torch.cat(seg) if seg else torch.zeros((0,), dtype=torch.long)
    ll = _segment_logsumexp(_score(out, s, p), s, len(rows))
    ok = torch.isfinite(ll)
    if not bool(ok.any()):
        none: Tensor = feats.sum() * 0.0
        return none
    loss: Tensor = -ll[ok].mean()
    return loss


def _first_outputs(model: StepModel, batch: EpisodeBatch, feats: Tensor,
                   pieces: list[list[int]], rows: list[int]) -> tuple[Tensor, Tensor, Tensor]:
    """Step outputs of first-step ``pieces`` of episodes ``rows`` (batch positions)."""
    tok = pad_tokens(pieces)
    r = torch.tensor(rows, dtype=torch.long)
    return model.step(model.code(tok), tok, feats[r], batch.centres[r],
                      torch.zeros((len(r), batch.mask.shape[1])), batch.mask[r])


def option_scores(model: StepModel, data: ProgramData, batch: EpisodeBatch, feats: Tensor,
                  options: list[list[int]]) -> list[Tensor]:
    """For each episode of ``batch``, the log-probability of its consistent programs under
    each option in ``options[i]`` (0: one step; c > 0: two steps cut at token c)."""
    assert data.consistent is not None
    firsts, first_row = [], []
    seconds, second_rows = [], []  # (option slot, first piece, program, episode row)
    slots: list[tuple[int, int]] = []
    for i, opts in enumerate(options):
        tok = batch.tokens[i]
        cons = data.consistent[batch.rows[i]]
        for c in opts:
            slots.append((i, c))
            firsts.append(tok if c == 0 else tok[:c])
            first_row.append(i)
            if c > 0:
                seconds.append(tok[c:])
                for j in range(len(cons.two)):
                    second_rows.append((len(slots) - 1, len(seconds) - 1, j, i))
    out1 = _first_outputs(model, batch, feats, firsts, first_row)
    score = torch.full((len(slots),), float("-inf"))
    # one-step options
    p_list, s_list = [], []
    for k, (i, c) in enumerate(slots):
        if c == 0:
            one = torch.from_numpy(data.consistent[batch.rows[i]].one)
            p_list.append(one)
            s_list.append(torch.full((len(one),), k, dtype=torch.long))
    if p_list and sum(len(p) for p in p_list):
        seg = torch.cat(s_list)
        one_step = _segment_logsumexp(_score(out1, seg, torch.cat(p_list)), seg, len(slots))
        is_one = torch.tensor([c == 0 for _, c in slots])
        score = torch.where(is_one, one_step, score)
    # two-step options: the second piece on the world each program's first step left
    if second_rows:
        sp = pad_tokens(seconds)
        slot = torch.tensor([x[0] for x in second_rows], dtype=torch.long)
        piece = torch.tensor([x[1] for x in second_rows], dtype=torch.long)
        ep = torch.tensor([x[3] for x in second_rows], dtype=torch.long)
        progs = torch.stack([torch.from_numpy(data.consistent[batch.rows[x[3]]].two[x[2]])
                             for x in second_rows])
        centres = batch.centres[ep].clone()
        for m, x in enumerate(second_rows):
            between = data.consistent[batch.rows[x[3]]].between[x[2]]
            centres[m, : len(between)] = torch.from_numpy(between).float()
        previous = torch.nn.functional.one_hot(progs[:, 0], batch.mask.shape[1]).float()
        code = model.code(sp)
        out2 = model.step(code[piece], sp[piece], feats[ep], centres, previous,
                          batch.mask[ep])
        joint = (_score(out1, slot, progs[:, :3])
                 + _score(out2, torch.arange(len(progs)), progs[:, 3:]))
        two_step = _segment_logsumexp(joint, slot, len(slots))
        is_two = torch.tensor([c > 0 for _, c in slots])
        score = torch.where(is_two, two_step, score)
    out: list[Tensor] = []
    k = 0
    for opts in options:
        out.append(score[k : k + len(opts)])
        k += len(opts)
    return out


@torch.no_grad()
def teacher_cuts(model: StepModel, data: ProgramData, rows: Sequence[int],
                 beam: int = 4) -> list[list[tuple[int, float]]]:
    """The options (0: one step, c: cut at token c) and the step model's posterior over
    them: how probable it finds each episode's consistent programs under each (the
    splitter's target, D4; empty where no option explains the episode).

    Cuts are tried where the prefix, read as a first step, best explains a consistent
    program's first step (the ``beam`` best), and one step always."""
    assert data.consistent is not None
    batch = EpisodeBatch(data, rows)
    feats = model.features(batch.crops, batch.mask, batch.sizes)
    prefixes, prow = [], []
    for i, tok in enumerate(batch.tokens):
        for c in range(1, len(tok)):
            prefixes.append(tok[:c])
            prow.append(i)
    options: list[list[int]] = [[0] for _ in rows]
    if prefixes:
        out1 = _first_outputs(model, batch, feats, prefixes, prow)
        k = 0
        for i, tok in enumerate(batch.tokens):
            two = data.consistent[batch.rows[i]].two
            n = len(tok) - 1
            if len(two) and n > 0:
                firsts = torch.unique(torch.from_numpy(two[:, :3]), dim=0)
                fit = torch.stack([
                    _score(out1, torch.full((len(firsts),), k + c), firsts).logsumexp(0)
                    for c in range(n)])
                best = torch.argsort(fit, descending=True, stable=True)[:beam] + 1
                options[i] += [int(c) for c in best]
            k += n
    scores = option_scores(model, data, batch, feats, options)
    return [[(c, float(w)) for c, w in zip(opts, torch.softmax(sc, 0).tolist(), strict=True)
             if w > 0] if bool(torch.isfinite(sc).any()) else []
            for opts, sc in zip(options, scores, strict=True)]


def joined_instructions(
    tokens: Sequence[Sequence[int]], posteriors: Sequence[Sequence[tuple[int, float]]],
    joins: int,
) -> tuple[list[list[int]], list[list[tuple[int, float]]]]:
    """The splitter's training rows: each instruction alone, then followed by the next 1,
    2, .. ``joins`` of the batch (cyclically), with each row's cuts and their weights: a
    sure boundary at every junction, and each part's posterior over its own cuts (a cut
    at 0 is no boundary) moved to where the part begins."""
    rows_tokens: list[list[int]] = []
    rows_cuts: list[list[tuple[int, float]]] = []
    n = len(tokens)
    for i in range(n):
        row: list[int] = []
        cuts: list[tuple[int, float]] = []
        for k in range(min(joins, n - 1) + 1):
            j = (i + k) % n
            if row:
                cuts.append((len(row), 1.0))
            cuts.extend((len(row) + c, w) for c, w in posteriors[j] if c > 0)
            row.extend(tokens[j])
            rows_tokens.append(list(row))
            rows_cuts.append(list(cuts))
    return rows_tokens, rows_cuts


def joint_loss(model: StepModel, splitter: Splitter, data: ProgramData,
               rows: Sequence[int], keep: int = 2, joins: int = 0) -> Tensor:
    """The joint stage's loss: the splitter learns the teacher's posterior over cuts
    (binary cross-entropy per token, soft targets), the step model the marginal
    likelihood of the consistent programs over the teacher's ``keep`` best options.

    ``joins`` > 0: the splitter also reads each instruction of the batch followed by the
    next ``joins`` ones (their tokens one after another, as a longer instruction of up to
    ``2 * (joins + 1)`` steps), with a boundary at each junction and each part's
    posterior at its place: training instructions have one or two steps, and a splitter
    that only ever read those holds weaker peaks in longer ones (under-cut)."""
    posts = teacher_cuts(model, data, rows)
    kept = [(r, sorted(p, key=lambda x: -x[1])[:keep], p)
            for r, p in zip(rows, posts, strict=True) if p]
    if not kept:
        return sum((p.sum() * 0.0 for p in splitter.parameters()), torch.zeros(()))
    batch = EpisodeBatch(data, [r for r, _, _ in kept])
    feats = model.features(batch.crops, batch.mask, batch.sizes)
    scores = option_scores(model, data, batch, feats, [[c for c, _ in k] for _, k, _ in kept])
    ll = torch.stack([torch.logsumexp(sc, 0) for sc in scores])
    ok = torch.isfinite(ll)
    step_loss = -ll[ok].mean() if bool(ok.any()) else feats.sum() * 0.0
    rows_tokens, rows_cuts = joined_instructions(batch.tokens, [p for _, _, p in kept], joins)
    logits = splitter(pad_tokens(rows_tokens))
    target = torch.zeros_like(logits)
    for i, cuts in enumerate(rows_cuts):
        for c, w in cuts:
            target[i, c] += w
    valid = torch.isfinite(logits)
    split_loss = torch.nn.functional.binary_cross_entropy_with_logits(
        logits[valid], target[valid].clamp(0.0, 1.0))
    return step_loss + split_loss


def fit_threshold(top: Tensor, cut: Tensor) -> float:
    """The splitter's threshold (see :func:`fit_calibration`) from each episode's two
    largest peak masses ``top`` (E, 2) and whether the teacher cuts it once ``cut`` (E,):
    the lowest of 0.01, 0.02, .., 0.99 that counts within ``THRESHOLD_TOLERANCE`` of the
    most episodes right."""
    grid = torch.linspace(0.01, 0.99, 99)
    th = grid.double()[:, None]
    right = (((top[:, 0] >= th) == cut) & (top[:, 1] < th)).sum(1)
    good = grid[right >= (1.0 - THRESHOLD_TOLERANCE) * right.max()]
    return float(good.min())


@torch.no_grad()
def fit_calibration(model: StepModel, splitter: Splitter, data: ProgramData,
                    rows: Sequence[int]) -> None:
    """Fit the splitter's rule for how many steps an instruction has on training episodes
    ``rows``, against the teacher's most probable number of boundaries (0 or 1: the cut
    the consistent programs favour, from the boxes alone):

    - ``threshold``: the window mass a peak needs to be a boundary
      (:meth:`Splitter.peaks`): the lowest threshold that counts within
      ``THRESHOLD_TOLERANCE`` of the most episodes right (the largest peak of an
      instruction with no boundary below it, of one with a boundary at or above it, its
      second peak below). On one- and two-step episodes a wide range counts as well as
      the best (0.28-0.50 within one episode of 512, the teacher's own noise), and an
      instruction of more steps holds weaker peaks: the middle of that range (0.405)
      under-cut 3-7 step instructions of a development part in 80 of 300, its low end
      (0.28) in 38 (and over-cut 2);
    - ``calibration`` (a, b): least squares of the summed boundary probabilities on the
      count (the earlier rule, kept in the checkpoint for comparison).

    Left as they are where the fit is degenerate (fewer than ten episodes of either
    count; a slope below 0.1)."""
    splitter.eval()
    posts = teacher_cuts(model, data, rows)
    kept = [(r, max(p, key=lambda x: x[1])[0] > 0) for r, p in zip(rows, posts, strict=True)
            if p]
    if sum(c for _, c in kept) < 10 or sum(not c for _, c in kept) < 10:
        return
    tokens = [data.tokens[r] for r, _ in kept]
    probs = torch.sigmoid(splitter(pad_tokens(tokens)))
    # each episode's two largest peaks (0 where it has fewer)
    top = torch.tensor([([m for _, m in splitter.peaks(probs[i, : len(t)])] + [0.0, 0.0])[:2]
                        for i, t in enumerate(tokens)], dtype=torch.float64)
    cut = torch.tensor([c for _, c in kept])
    splitter.threshold = torch.tensor(fit_threshold(top, cut))
    total = torch.stack([probs[i, : len(t)].sum() for i, t in enumerate(tokens)]).double()
    count = torch.tensor([float(c) for _, c in kept], dtype=torch.float64)
    x = torch.stack([count, torch.ones_like(count)], 1)
    a, b = torch.linalg.lstsq(x, total[:, None]).solution[:, 0].tolist()
    if a >= 0.1:
        splitter.calibration = torch.tensor([a, b])
