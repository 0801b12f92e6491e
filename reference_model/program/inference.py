"""A program model at inference: split, then run step after step on the world the
previous steps left, and write what it did as predictions.

The splitter makes as many cuts as its calibrated boundary probabilities say, at their
peaks (any number of steps);
each piece's action is the most probable one (the same distribution training scores, D1),
its subject and base the best pair of distinct objects that the DSL allows on the stacks
the previous steps built (:func:`legal_pairs`: no object under another is picked up, none
is stacked onto a covered object or onto its own support, no stack grows past
``MAX_STACK``); the action rule moves the
subject in 3D (D7), and positions are the moved objects' 3D centres (D8).

:class:`Oracle` replaces parts of the model by the gold answer, one at a time, for the
oracle ladder of the diagnosis (``benchmarks/diagnose_program_model.py``); a model never
reads it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
import torch
from numpy.typing import NDArray
from torch import Tensor

from nsrmp_bench.dsl.actions import MAX_STACK
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.reference_model.predictions import model_predictions
from nsrmp_bench.reference_model.program.data import ProgramData
from nsrmp_bench.reference_model.program.modules import Splitter, StepModel
from nsrmp_bench.reference_model.program.scene3d import TOP, ActionRule, move, project_boxes
from nsrmp_bench.reference_model.program.training import EpisodeBatch, pad_tokens
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["Decoded", "Oracle", "decode", "decoded_iou_m", "decoded_predictions",
           "legal_pairs"]



def legal_pairs(on: Sequence[int], action: int, n: int) -> NDArray[np.bool_]:
    """(n, n) which (subject, base) pairs the DSL allows for ``action`` when object ``i``
    rests on object ``on[i]`` (-1: on the table; objects past ``len(on)`` are padding): the
    two differ, the subject carries nothing; for ``top`` the base carries nothing, is not
    under the subject, and its stack has room."""
    legal = ~np.eye(n, dtype=bool)
    under = {b for b in on if b >= 0}
    for b in under:
        legal[b, :] = False
    if action == TOP:
        for b in under:
            legal[:, b] = False
        for i in range(len(on)):
            level, j, seen = 1, on[i], 0
            while j >= 0 and seen < len(on):
                legal[i, j] = False  # onto its own support (or below it)
                level, j, seen = level + 1, on[j], seen + 1
            if level >= MAX_STACK:
                legal[:, i] = False
    return legal


@dataclass(frozen=True)
class Oracle:
    """Gold parts that replace the model's (per episode; None: the model's own)."""

    cuts: list[list[int]] | None = None  # token positions where steps 2.. start
    actions: list[list[int]] | None = None  # action index per step
    grounding: list[list[tuple[int, int]]] | None = None  # (subject, base) per step


@dataclass
class Decoded:
    """Per episode: steps (action, subject, base), boxes (S, N, 4) and camera depths
    (S, N) after each step, and the final centres (N, 3)."""

    steps: list[list[tuple[int, int, int]]] = field(default_factory=list)
    boxes: list[NDArray[np.float64]] = field(default_factory=list)
    depths: list[NDArray[np.float64]] = field(default_factory=list)
    centres: list[NDArray[np.float64]] = field(default_factory=list)


@torch.no_grad()
def decode(model: StepModel, splitter: Splitter, data: ProgramData, rule: ActionRule,
           oracle: Oracle | None = None, batch_size: int = 64,
           perceived: Callable[[Tensor, Tensor], Tensor] | None = None) -> Decoded:
    """Run the model over every episode of ``data`` (``perceived``: the sizes (B, N, 2) the
    perception reads, from the estimated ones and the mask; default: those)."""
    model.eval()
    splitter.eval()
    oracle = oracle or Oracle()
    out = Decoded()
    for start in range(0, len(data), batch_size):
        rows = list(range(start, min(start + batch_size, len(data))))
        batch = EpisodeBatch(data, rows)
        cuts = ([oracle.cuts[r] for r in rows] if oracle.cuts is not None
                else splitter.cuts(batch.tokens))
        pieces = [[tok[a:b] for a, b in zip([0, *c], [*c, len(tok)], strict=True)]
                  for tok, c in zip(batch.tokens, cuts, strict=True)]
        sizes = batch.sizes if perceived is None else perceived(batch.sizes, batch.mask)
        feats = model.features(batch.crops, batch.mask, sizes)
        n_obj = batch.mask.shape[1]
        centres = [data.states[r].centres.copy() for r in rows]
        previous = torch.zeros((len(rows), n_obj))
        on = [[-1] * len(data.states[r]) for r in rows]
        steps: list[list[tuple[int, int, int]]] = [[] for _ in rows]
        boxes: list[list[NDArray[np.float64]]] = [[] for _ in rows]
        depths: list[list[NDArray[np.float64]]] = [[] for _ in rows]
        for k in range(max(len(p) for p in pieces)):
            act = [i for i, p in enumerate(pieces) if len(p) > k]
            idx = torch.tensor(act, dtype=torch.long)
            toks = pad_tokens([pieces[i][k] for i in act])
            cen = torch.zeros((len(act), n_obj, 3))
            for j, i in enumerate(act):
                cen[j, : len(centres[i])] = torch.from_numpy(centres[i]).float()
            s_lp, b_lp, a_lp = model.step(model.code(toks), toks, feats[idx], cen,
                                          previous[idx], batch.mask[idx])
            pair = s_lp[:, :, None] + b_lp[:, None, :]
            pair = pair.masked_fill(torch.eye(n_obj, dtype=torch.bool)[None], float("-inf"))
            for j, i in enumerate(act):
                r = rows[i]
                action = int(a_lp[j].argmax())
                if oracle.actions is not None and k < len(oracle.actions[r]):
                    action = oracle.actions[r][k]
                legal = torch.from_numpy(legal_pairs(on[i], action, n_obj))
                scores = pair[j].masked_fill(~legal, float("-inf"))
                if not bool(torch.isfinite(scores).any()):
                    scores = pair[j]  # nothing legal: the best pair regardless
                subj, base = divmod(int(scores.reshape(-1).argmax()), n_obj)
                if oracle.grounding is not None and k < len(oracle.grounding[r]):
                    subj, base = oracle.grounding[r][k]
                on[i][subj] = base if action == TOP else -1
                state = data.states[r]
                centres[i] = move(state, centres[i][None], np.array([subj]), np.array([base]),
                                  np.array([action]), rule)[0]
                steps[i].append((action, subj, base))
                boxes[i].append(project_boxes(state, centres[i]))
                depths[i].append(state.camera.project(centres[i])[1])
                previous[i] = 0.0
                previous[i, subj] = 1.0
        for i, r in enumerate(rows):
            n = len(data.states[r])
            out.steps.append(steps[i])
            out.boxes.append(np.stack(boxes[i]) if boxes[i] else np.zeros((0, n, 4)))
            out.depths.append(np.stack(depths[i]) if depths[i] else np.zeros((0, n)))
            out.centres.append(centres[i])
    return out


def decoded_iou_m(data: ProgramData, decoded: Decoded) -> float:
    """Mean IoU of the gold-moved objects' predicted and final boxes (the in-loop
    validation score; the public scorer computes the official one)."""
    from nsrmp_bench.geometry.boxes import box_iou
    from nsrmp_bench.reference_model.program.consistent import changed_boxes

    assert data.enc.final_boxes is not None
    total, count = 0.0, 0
    for i, state in enumerate(data.states):
        n = len(state)
        init = data.enc.boxes[i, :n].numpy()
        final = data.enc.final_boxes[i, :n].numpy()
        pred = decoded.boxes[i][-1] if len(decoded.boxes[i]) else init
        moved = changed_boxes(init, final)
        if moved.any():
            total += float(box_iou(pred[moved], final[moved]).mean())
            count += 1
    return total / max(count, 1)


def decoded_predictions(ids: Sequence[str], data: ProgramData, decoded: Decoded,
                        camera: Camera) -> Iterator[Prediction]:
    """The decoded programs as predictions (the shared predictions writer)."""
    init = [data.enc.boxes[i, : len(s)].numpy() for i, s in enumerate(data.states)]
    return model_predictions(ids, init, decoded.steps, decoded.boxes, decoded.depths, camera)
