"""The metrics of ``scorer-v1`` and ``scorer-v2``: per-instance values, vectorised over a
whole split.

``scorer-v2`` reports every figure of ``scorer-v1``, with the same value, and three more
(below, after the ``scorer-v1`` ones). Definitions (``nsrmp_bench/scoring/metrics.py`` is
their reference; ``SCORING.md`` repeats them):

* **IoU**: mean over all objects of IoU(predicted final amodal box, gold final amodal box),
  objects matched by index (episode order). Per instance, then averaged over instances.
* **IoU-M** (the headline): the same mean over the objects the gold program moves (each
  once). A do-nothing predictor scores about (N-k)/N on IoU but near 0 on IoU-M.
* **Program accuracy**, for each of *action*, *subject* and *predicate* (the reference
  object): ``*_all_steps`` is 1 iff the predicted program has the gold number of steps and
  every step's field matches (the original NSRM's subject / predicate accuracy);
  ``*_per_step`` is the number of steps k whose field matches gold step k, divided by
  max(gold steps, predicted steps) (the original NMN+'s "Arg O1/O2" and NSRM's action
  accuracy, which scored 0 on a step-count mismatch; here extra or missing steps count as
  wrong steps). ``program_exact``: all three right at every step, same number of steps.
* **Identification / placement accuracy** (the paper's CLIPort comparison; single-step
  instances only): the pick location lies in the gold *initial* box of the moved object,
  and the place location in its gold *final* box (borders included). Without a ``pick``,
  the pick location is the centre of the initial box of the predicted program's first
  subject; without a ``place``, the centre of the moved object's predicted final box.
  Unlike the original (model report §3.1, bug B1) the centre is ((x1+x2)/2, (y1+y2)/2) of
  the *predicted* box.
* **Success**: every moved object's final box has IoU >= 0.5 with gold, and, on lines that
  give ``positions``, every moved object's predicted centre lies within 2 cm of gold.
  ``success_2d`` and ``success_3d`` report the two parts (``success_3d`` only when some
  line gives positions; lines without positions score 0 on it).
* **Per-step IoU-M** (``iou_m_step_k``; only when some line gives ``step_boxes``): at the
  state after step k, mean IoU over the objects moved by steps 1..k, for instances with at
  least k steps; at k = S it is IoU-M computed from ``step_boxes``.

``scorer-v2`` adds:

* **Kept still** (``kept_still``): an object the gold leaves in place (not moved by any gold
  step) is *kept still* when its predicted final box has IoU >= 0.5 with its gold final box
  and, on lines that give ``positions``, its predicted centre lies within 2 cm of gold (the
  same tests as success). Per instance: the share of the objects the gold leaves in place
  that are kept still; NaN where the gold moves every object.
* **Strict success** (``success_strict``): success, and every object the gold leaves in
  place kept still. Defined for every instance: where the gold moves nothing, success holds
  vacuously and strict success is "every object kept still".
* **Abstention** (``abstention``): defined where the gold's ``abstain`` is set (``"no
  action"`` or ``"not feasible"``). The prediction's decision is its ``abstain`` value if
  it gives one; else ``"no action"`` if it moves nothing (its program is ``[]``, or it has
  no program and every object is kept still, tested as above against the gold final
  boxes); else "act". 1 iff the decision equals the gold's ``abstain``.

A missing instance scores 0 on every metric defined for it. NaN means "not defined for this
instance" (IoU-M with no moved object, identification on a two-step instance, per-step
IoU-M beyond the instance's steps) and takes no part in means or intervals.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nsrmp_bench.geometry.boxes import box_centres, box_iou, points_in_boxes
from nsrmp_bench.scoring.align import PredictionTable
from nsrmp_bench.scoring.gold import GoldTable
from nsrmp_bench.scoring.ragged import positions_in_rows
from nsrmp_bench.scoring.submission import ABSTAIN_CODES
from nsrmp_bench.scoring.version import SCORER_ID, SCORER_V1, check_scorer

__all__ = [
    "METRICS",
    "METRICS_V2",
    "SUCCESS_DISTANCE_M",
    "SUCCESS_IOU",
    "V2_METRICS",
    "MetricSpec",
    "instance_scores",
    "metric_spec",
    "metrics_of",
    "step_metric_name",
]

F64 = NDArray[np.float64]
B = NDArray[np.bool_]

SUCCESS_IOU = 0.5
"""A moved object's final box counts as placed at IoU >= this."""

SUCCESS_DISTANCE_M = 0.02
"""A moved object's predicted 3D centre counts as placed within this many metres."""


@dataclass(frozen=True)
class MetricSpec:
    """A reported figure: its name, what it measures, and its name in the paper."""

    name: str
    label: str
    description: str
    paper: str = ""


METRICS: tuple[MetricSpec, ...] = (
    MetricSpec("iou_m", "IoU-M", "mean IoU of final boxes over moved objects (headline)",
               "IoU-M (Table I)"),
    MetricSpec("iou", "IoU", "mean IoU of final boxes over all objects", "IoU (Table I)"),
    MetricSpec("success", "success",
               f"every moved object's box IoU >= {SUCCESS_IOU} (and centre within "
               f"{SUCCESS_DISTANCE_M * 100:g} cm where positions are given)"),
    MetricSpec("success_2d", "success 2D", f"every moved object's box IoU >= {SUCCESS_IOU}"),
    MetricSpec("success_3d", "success 3D",
               f"every moved object's centre within {SUCCESS_DISTANCE_M * 100:g} cm of gold"),
    MetricSpec("program_exact", "program exact",
               "same number of steps, and every step's action, subject and reference right"),
    MetricSpec("action_all_steps", "action (all steps)",
               "same number of steps and every step's action right"),
    MetricSpec("subject_all_steps", "subject (all steps)",
               "same number of steps and every step's subject right", "Subj (NSRM)"),
    MetricSpec("predicate_all_steps", "predicate (all steps)",
               "same number of steps and every step's reference object right", "Pred (NSRM)"),
    MetricSpec("action_per_step", "action (per step)",
               "share of steps whose action is right (extra/missing steps count wrong)",
               "Act (NSRM)"),
    MetricSpec("subject_per_step", "subject (per step)",
               "share of steps whose subject is right", "Subj (NMN+, Arg O1)"),
    MetricSpec("predicate_per_step", "predicate (per step)",
               "share of steps whose reference object is right", "Pred (NMN+, Arg O2)"),
    MetricSpec("identification", "identification",
               "single-step: pick location in the moved object's gold initial box",
               "Id. Acc. (Table II)"),
    MetricSpec("placement", "placement",
               "single-step: place location in the moved object's gold final box",
               "Pl. Acc. (Table II)"),
)
"""The instance-level figures of ``scorer-v1``, headline first (per-step IoU-M aside)."""

V2_METRICS: tuple[MetricSpec, ...] = (
    MetricSpec("success_strict", "strict success",
               "success, and every object the gold leaves in place kept still (defined for "
               "every instance)"),
    MetricSpec("kept_still", "kept still",
               f"share of the objects the gold leaves in place whose final box keeps IoU >= "
               f"{SUCCESS_IOU} (and centre within {SUCCESS_DISTANCE_M * 100:g} cm where "
               "positions are given)"),
    MetricSpec("abstention", "abstention",
               "where the gold abstains: the prediction's decision (its abstain; else 'no "
               "action' if it moves nothing; else act) equals the gold's"),
)
"""The figures ``scorer-v2`` adds to ``scorer-v1``'s."""

_V2_ORDER = ("iou_m", "iou", "success", "success_strict", "kept_still")
METRICS_V2: tuple[MetricSpec, ...] = (
    *(m for name in _V2_ORDER for m in (*METRICS, *V2_METRICS) if m.name == name),
    *(m for m in METRICS if m.name not in _V2_ORDER),
    *(m for m in V2_METRICS if m.name not in _V2_ORDER),
)
"""The figures of ``scorer-v2`` in report order: strict success and kept still beside
success, abstention last."""


def metrics_of(scorer: str = SCORER_ID) -> tuple[MetricSpec, ...]:
    """The instance-level figures a scorer reports, in report order."""
    return METRICS if check_scorer(scorer) == SCORER_V1 else METRICS_V2


def metric_spec(name: str) -> MetricSpec | None:
    """The spec of a figure of any scorer, or None (per-step IoU-M)."""
    return _ALL_SPECS.get(name)


_ALL_SPECS = {m.name: m for m in METRICS_V2}


def step_metric_name(k: int) -> str:
    """The column name of per-step IoU-M after step ``k`` (1-based)."""
    return f"iou_m_step_{k}"


def _per_instance(index: NDArray[np.int64], weights: NDArray[Any], n: int) -> F64:
    out: F64 = np.bincount(index, weights=weights, minlength=n).astype(np.float64)
    return out


def _safe_div(num: NDArray[Any], den: NDArray[Any]) -> F64:
    with np.errstate(invalid="ignore", divide="ignore"):
        out: F64 = np.where(den > 0, num / np.where(den > 0, den, 1), np.nan)
    return out


def instance_scores(gold: GoldTable, pred: PredictionTable, *, scorer: str = SCORER_ID,
                    ) -> tuple[pd.DataFrame, dict[str, int]]:
    """Per-instance values of every metric of ``scorer`` (index: instance id) and source
    counts.

    The frame also holds ``present`` and the gold categories; the counts say how the pick
    and place locations were obtained.
    """
    v2 = check_scorer(scorer) != SCORER_V1
    n = gold.n_instances
    present = pred.present
    obj_inst = gold.obj_instance
    obj_present = present[obj_inst]

    # Final boxes.
    if pred.object_matched is not None:  # detected objects: an unmatched one scores 0
        obj_present = obj_present & pred.object_matched
    iou_obj = np.where(obj_present, box_iou(pred.boxes, gold.final_boxes), 0.0)
    iou = _safe_div(_per_instance(obj_inst, iou_obj, n), gold.n_objects)
    iou_m = _safe_div(_per_instance(obj_inst, iou_obj * gold.moved, n), gold.n_moved)
    fail_2d = _per_instance(obj_inst, gold.moved & (iou_obj < SUCCESS_IOU), n)
    success_2d = present & (fail_2d == 0)

    any_pos = bool(pred.has_positions.any())
    dist = np.linalg.norm(pred.positions - gold.final_positions, axis=1)
    with np.errstate(invalid="ignore"):
        near = dist <= SUCCESS_DISTANCE_M  # NaN (no positions) -> False
    fail_3d = _per_instance(obj_inst, gold.moved & ~near, n)
    success_3d_inst = present & pred.has_positions & (fail_3d == 0)
    success = success_2d & (~pred.has_positions | success_3d_inst)
    if v2:  # what stayed still, with success's own tests
        kept = (iou_obj >= SUCCESS_IOU) & (~pred.has_positions[obj_inst] | near)
        still = ~gold.moved
        n_still = gold.n_objects - gold.n_moved
        kept_still = _safe_div(_per_instance(obj_inst, kept & still, n), n_still)
        n_not_kept = _per_instance(obj_inst, ~kept, n)
        moved_still = _per_instance(obj_inst, still & ~kept, n)
        success_strict = success & (moved_still == 0)

    # Programs: gold step k of an instance against predicted step k.
    step_inst = gold.step_instance
    k = positions_in_rows(gold.step_offsets)
    pred_len = pred.n_program_steps
    valid = k < pred_len[step_inst]
    j = np.where(valid, pred.program_offsets[step_inst] + k, 0)
    if len(pred.actions):
        act_ok = valid & (pred.actions[j] == gold.actions)
        sub_ok = valid & (pred.subjects[j] == gold.subjects)
        ref_ok = valid & (pred.references[j] == gold.references)
    else:
        act_ok = sub_ok = ref_ok = np.zeros(len(k), dtype=bool)
    same_len = pred.has_program & (pred_len == gold.n_steps)
    denom = np.maximum(gold.n_steps, pred_len)
    both_empty = pred.has_program & (denom == 0)
    cols: dict[str, F64] = {
        "iou_m": iou_m,
        "iou": iou,
        "success": success.astype(np.float64),
        "success_2d": success_2d.astype(np.float64),
        "success_3d": success_3d_inst.astype(np.float64) if any_pos else np.full(n, np.nan),
    }
    if v2:
        cols["success_strict"] = success_strict.astype(np.float64)
        cols["kept_still"] = kept_still
    exact = _per_instance(step_inst, act_ok & sub_ok & ref_ok, n)
    cols["program_exact"] = (same_len & (exact == gold.n_steps)).astype(np.float64)
    matches = {}
    for name, ok in (("action", act_ok), ("subject", sub_ok), ("predicate", ref_ok)):
        m = _per_instance(step_inst, ok, n)
        matches[name] = m
        cols[f"{name}_all_steps"] = (same_len & (m == gold.n_steps)).astype(np.float64)
    for name in ("action", "subject", "predicate"):
        per = np.where(denom > 0, _safe_div(matches[name], denom), both_empty.astype(np.float64))
        cols[f"{name}_per_step"] = np.where(pred.has_program, per, 0.0)

    # Identification and placement on single-step instances.
    single = gold.single_step
    first = np.minimum(gold.step_offsets[:-1], max(len(gold.subjects) - 1, 0))
    gold_subject = gold.subjects[first] if len(gold.subjects) else np.zeros(n, dtype=np.int64)
    obj_moved = gold.obj_offsets[:-1] + np.where(single, gold_subject, 0)
    has_first = present & pred.has_program & (pred_len > 0)
    p_first = np.minimum(pred.program_offsets[:-1], max(len(pred.subjects) - 1, 0))
    pred_first = pred.subjects[p_first] if len(pred.subjects) else np.zeros(n, dtype=np.int64)
    pred_subject = np.where(has_first, pred_first, 0)
    derived_pick = box_centres(gold.initial_boxes[gold.obj_offsets[:-1] + pred_subject])
    pick_given = present & ~np.isnan(pred.pick[:, 0])
    pick = np.where(has_first[:, None], derived_pick, np.nan)
    pick = np.where(pick_given[:, None], pred.pick, pick)
    place_given = present & ~np.isnan(pred.place[:, 0])
    place = np.where(present[:, None], box_centres(pred.boxes[obj_moved]), np.nan)
    place = np.where(place_given[:, None], pred.place, place)
    ident = present & points_in_boxes(pick, gold.initial_boxes[obj_moved])
    placed = present & points_in_boxes(place, gold.final_boxes[obj_moved])
    cols["identification"] = np.where(single, ident.astype(np.float64), np.nan)
    cols["placement"] = np.where(single, placed.astype(np.float64), np.nan)
    if v2:
        gold_abstain = gold.abstain_codes
        pred_abstain = pred.abstain_codes
        moves_nothing = np.where(pred.has_program, pred_len == 0, n_not_kept == 0)
        no_action = np.int8(ABSTAIN_CODES["no action"])
        decision = np.where(pred_abstain > 0, pred_abstain,
                            np.where(moves_nothing, no_action, np.int8(0)))
        right = present & (decision == gold_abstain)
        cols["abstention"] = np.where(gold_abstain > 0, right.astype(np.float64), np.nan)

    # Per-step IoU-M from step boxes.
    if pred.has_step_boxes.any():
        sb_inst = gold.step_instance[gold.stepbox_step]
        sb_ok = pred.has_step_boxes[sb_inst]
        iou_sb = np.where(sb_ok, box_iou(pred.step_boxes, gold.step_boxes), 0.0)
        t_count = len(gold.subjects)
        num = np.bincount(gold.stepbox_step, weights=iou_sb * gold.stepbox_moved, minlength=t_count)
        den = np.bincount(gold.stepbox_step, weights=gold.stepbox_moved, minlength=t_count)
        step_val = _safe_div(num, den)
        for kk in range(1, gold.max_steps + 1):
            col = np.full(n, np.nan)
            sel = k == kk - 1
            col[step_inst[sel]] = step_val[sel]
            cols[step_metric_name(kk)] = col

    frame = pd.DataFrame(cols, index=pd.Index(gold.ids, name="id"))
    frame.insert(0, "present", present)
    for c in gold.categories.columns:
        frame[c] = gold.categories[c].to_numpy()
    counts = {
        "single_step": int(single.sum()),
        "pick_given": int((single & pick_given).sum()),
        "pick_from_program": int((single & ~pick_given & has_first).sum()),
        "place_given": int((single & place_given).sum()),
        "place_from_boxes": int((single & ~place_given & present).sum()),
    }
    return frame, counts
