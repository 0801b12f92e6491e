"""Which grounded programs explain a training episode: the box-derived training signal.

A program model is supervised by the initial and final boxes only. Every grounded program
of one or two steps (subject, base, action) is run through the action rule
(:mod:`.scene3d`) from the initial state; a program is *consistent* when every object's
predicted final box overlaps its gold final box by at least ``min_iou`` (and scores
within ``slack`` of the best program). Training maximises the probability of the set of
consistent programs, so an episode whose first step is hidden (the same object moved
twice) supervises only what the boxes show. Neither the gold program nor any label is
read: only boxes, depth and the camera.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.geometry.boxes import box_iou
from nsrmp_bench.reference_model.program.scene3d import (
    LEFT,
    TOP,
    ActionRule,
    SceneState,
    move,
    project_boxes,
    rule_features,
)

__all__ = [
    "Consistent",
    "all_steps",
    "changed_boxes",
    "consistent_programs",
    "explained",
    "fit_rule",
]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


@dataclass(frozen=True)
class Consistent:
    """An episode's consistent programs: one-step ``(M1, 3)`` rows (subject, base,
    action), two-step ``(M2, 6)`` rows, and each two-step program's centres after its first
    step ``(M2, N, 3)`` (where its second step's references resolve)."""

    one: I64
    two: I64
    between: F64


def all_steps(n: int) -> I64:
    """Every grounded step (subject, base, action) of a scene of ``n`` objects: (K, 3)."""
    s, b, a = np.meshgrid(np.arange(n), np.arange(n), np.arange(3), indexing="ij")
    steps = np.stack([s.ravel(), b.ravel(), a.ravel()], axis=1)
    out: I64 = steps[steps[:, 0] != steps[:, 1]].astype(np.int64)
    return out


def changed_boxes(initial: NDArray[np.floating], final: NDArray[np.floating],
                  min_iou: float = 0.8) -> NDArray[np.bool_]:
    """Which objects' boxes changed (IoU of initial and final box below ``min_iou``)."""
    out: NDArray[np.bool_] = box_iou(initial, final) < min_iou
    return out


def _run(state: SceneState, centres: F64, steps: I64, rule: ActionRule) -> F64:
    return move(state, centres, steps[:, 0], steps[:, 1], steps[:, 2], rule)


def explained(state: SceneState, final: NDArray[np.floating], rule: ActionRule
              ) -> tuple[I64, F64]:
    """Every one-step program and how well it explains ``final``: the worst object's IoU
    of predicted and gold final box, (K,)."""
    steps = all_steps(len(state))
    centres = np.broadcast_to(state.centres, (len(steps), *state.centres.shape))
    boxes = project_boxes(state, _run(state, centres, steps, rule))
    return steps, box_iou(boxes, np.asarray(final)[None]).min(axis=1)


def consistent_programs(state: SceneState, final: NDArray[np.floating], rule: ActionRule,
                        *, min_iou: float = 0.5, slack: float = 0.15,
                        max_two: int = 64) -> Consistent:
    """The one- and two-step programs that explain ``final`` (see the module doc).

    At most ``max_two`` two-step programs are kept (the best-scoring ones).
    """
    gold = np.asarray(final, dtype=np.float64)[None]
    steps = all_steps(len(state))
    k = len(steps)
    start = np.broadcast_to(state.centres, (k, *state.centres.shape))
    after1 = _run(state, start, steps, rule)
    score1 = box_iou(project_boxes(state, after1), gold).min(axis=1)
    first = np.repeat(np.arange(k), k)
    second = np.tile(np.arange(k), k)
    after2 = _run(state, after1[first], steps[second], rule)
    score2 = box_iou(project_boxes(state, after2), gold).min(axis=1)
    best = max(float(score1.max()), float(score2.max()))
    floor = max(min_iou, best - slack)
    one = steps[score1 >= floor]
    keep = np.flatnonzero(score2 >= floor)
    keep = keep[np.argsort(-score2[keep], kind="stable")[:max_two]]
    two = np.concatenate([steps[first[keep]], steps[second[keep]]], axis=1)
    return Consistent(one.astype(np.int64), two.astype(np.int64), after1[first[keep]])


def fit_rule(states: Sequence[SceneState], finals: Sequence[NDArray[np.floating]],
             initial: ActionRule | None = None, rounds: int = 3) -> ActionRule:
    """The rule's weights that best explain episodes where exactly one box changed.

    Each round takes every episode's best one-step program under the current rule, reads
    where the final box puts the mover (``top``: the point of the ray through the final
    box's centre above the base; ``left``/``right``: where that ray meets the mover's
    resting height) and fits the lift and the side distance to it by least squares over
    their features, dropping residuals beyond three robust deviations. (``centre`` shapes
    the states themselves and stays fixed.)"""
    rule = initial or ActionRule()
    for _ in range(rounds):
        rows: dict[bool, list[F64]] = {True: [], False: []}
        want: dict[bool, list[float]] = {True: [], False: []}
        for state, final in zip(states, finals, strict=True):
            steps, score = explained(state, final, rule)
            best = int(np.argmax(score))
            if score[best] < 0.5:
                continue
            s, b, a = (int(v) for v in steps[best])
            got = _offset(state, np.asarray(final, dtype=np.float64)[s], s, b, a)
            if got is None:
                continue
            rows[a == TOP].append(rule_features(state, np.array([s]), np.array([b]))[0])
            want[a == TOP].append(got)
        top = _robust_lstsq(rows[True], want[True], rule.top)
        side = _robust_lstsq(rows[False], want[False], rule.side)
        rule = ActionRule(rule.centre, top, side)
    return rule


def _offset(state: SceneState, box: F64, s: int, b: int, a: int) -> float | None:
    """Where ``box`` (the mover ``s``'s final box) puts the mover relative to base ``b``:
    for ``top`` the lift of the point of the ray through the box's centre above the base,
    for ``left``/``right`` the distance beside the base (along the side's direction) where
    that ray meets the mover's resting height; None when the ray gives no such point."""
    uv = np.array([(box[0] + box[2]) / 2, (box[1] + box[3]) / 2])
    base = state.centres[b]
    if a == TOP:
        eye = np.asarray(state.camera.eye, dtype=np.float64)
        ray = state.camera.backproject(uv, np.ones(())) - eye
        flat = float(ray[:2] @ ray[:2])
        if flat < 1e-12:
            return None
        t = float((base[:2] - eye[:2]) @ ray[:2] / flat)
        return float(eye[2] + t * ray[2] - base[2])
    cut = state.camera.ray_at_height(uv, float(state.centres[s, 2]))
    if cut is None:
        return None
    return (-1.0 if a == LEFT else 1.0) * float(cut[0] - base[0])


def _robust_lstsq(rows: list[F64], want: list[float],
                  fallback: tuple[float, ...]) -> tuple[float, ...]:
    """Least squares ``rows @ w = want``, refitted without residuals beyond three robust
    deviations; ``fallback`` when there are too few rows to fit."""
    if len(rows) < 4 * len(fallback):
        return fallback
    x, y = np.asarray(rows), np.asarray(want)
    w = np.linalg.lstsq(x, y, rcond=None)[0]
    r = y - x @ w
    mad = float(np.median(np.abs(r - np.median(r)))) * 1.4826
    keep = np.abs(r) <= 3 * max(mad, 1e-6)
    if int(keep.sum()) >= 4 * len(fallback):
        w = np.linalg.lstsq(x[keep], y[keep], rcond=None)[0]
    return tuple(float(v) for v in w)
