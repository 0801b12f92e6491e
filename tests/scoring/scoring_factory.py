"""Episodes, predictions and synthetic tables for the scoring tests and benchmark.

* :func:`boxed_episode` makes a rendered episode whose gold boxes (and positions) are given
  directly, for metrics checked against hand-computed values.
* :func:`synthetic_tables` makes a random gold table and an aligned prediction table of
  any size straight from numpy (for cross-checks and the throughput benchmark).
* :func:`loop_scores` is a plain per-instance Python implementation of the main metrics,
  written independently of the vectorised scorer, used to cross-check it and as the
  benchmark's baseline.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from nsrmp_bench.dsl.program import GroundedStep, Node, Program
from nsrmp_bench.episode import (
    Episode,
    Instruction,
    ObjectTargets,
    Rendering,
    SeedInfo,
    SymbolicEpisode,
)
from nsrmp_bench.geometry.default_camera import official_camera
from nsrmp_bench.scene import Pose, Scene, SceneObject
from nsrmp_bench.scoring.align import PredictionTable
from nsrmp_bench.scoring.gold import GoldTable
from nsrmp_bench.scoring.ragged import offsets_from_lengths
from nsrmp_bench.scoring.submission import Prediction, SubmissionHeader
from nsrmp_bench.vocabulary import COLOURS, SHAPES

SPLIT = "unit-v1"
HEADER = SubmissionHeader(split=SPLIT, model="test")


def objects_for(n: int) -> tuple[SceneObject, ...]:
    """n objects with distinct (shape, colour)."""
    return tuple(SceneObject(SHAPES[(i // len(COLOURS)) % len(SHAPES)], COLOURS[i % len(COLOURS)])
                 for i in range(n))


def program_for(objects: Sequence[SceneObject], steps: Sequence[GroundedStep],
                relational: bool = False) -> Program:
    """A type-checked program whose references name each object by colour and shape."""
    nodes: list[Node] = [Node("idle")]
    chain = 0

    def ref(i: int) -> int:
        nodes.append(Node("scene"))
        nodes.append(Node("filter", (len(nodes) - 1,), (objects[i].colour,)))
        nodes.append(Node("filter", (len(nodes) - 1,), (objects[i].shape,)))
        nodes.append(Node("unique", (len(nodes) - 1,)))
        return len(nodes) - 1

    for step in steps:
        s = ref(step.subject)
        r = ref(step.reference)
        if relational:
            nodes.append(Node("relate", (r,), ("left",)))
            nodes.append(Node("unique", (len(nodes) - 1,)))
            r = len(nodes) - 1
        nodes.append(Node("move", (chain, s, r), (step.action,)))
        chain = len(nodes) - 1
    return Program(tuple(nodes))


def boxed_episode(
    eid: str,
    boxes: Any,
    steps: Sequence[tuple[str, int, int]],
    *,
    positions: Any = None,
    relational: bool = False,
    phrasing: str = "simple",
    template: str = "T01",
    size: tuple[int, int] = (320, 240),
) -> Episode:
    """A rendered episode with gold amodal boxes ``boxes`` (S+1, N, 4) given directly."""
    b = np.asarray(boxes, dtype=np.float32)
    k, n, _ = b.shape
    if positions is None:
        positions = np.zeros((k, n, 3))
        positions[..., 0] = np.arange(n) * 0.1
    pos = np.asarray(positions, dtype=np.float64)
    objects = objects_for(n)
    grounded = tuple(GroundedStep(a, s, r) for a, s, r in steps)
    states = tuple(tuple(Pose(tuple(float(v) for v in p)) for p in state) for state in pos)
    sym = SymbolicEpisode(
        id=eid,
        generator="unit",
        seed=SeedInfo(0, 0),
        scene=Scene(objects, states[0]),
        program=program_for(objects, grounded, relational),
        grounded=grounded,
        instruction=Instruction("do it", template, phrasing),
        states=states,
    )
    poses = np.concatenate([pos, np.tile([0.0, 0.0, 0.0, 1.0], (k, n, 1))], axis=-1)
    targets = ObjectTargets(
        poses=poses,
        boxes_amodal=b,
        boxes_visible=b.copy(),
        visible_fraction=np.ones((k, n), dtype=np.float32),
        depth_centre=np.ones((k, n), dtype=np.float32),
    )
    return Episode(sym, Rendering(official_camera(*size), None, targets))


def prediction(eid: str, boxes: Any, **fields: Any) -> Prediction:
    """A prediction with ``boxes`` and optional fields (program as (action, s, r) tuples)."""
    program = fields.pop("program", None)
    if program is not None:
        fields["program"] = tuple(GroundedStep(a, s, r) for a, s, r in program)
    return Prediction(id=eid, boxes=np.asarray(boxes, dtype=np.float64), **fields)


# -- synthetic tables ---------------------------------------------------------------------
def _random_boxes(rng: np.random.Generator, m: int, w: float = 320, h: float = 240) -> Any:
    x1 = rng.uniform(0, w - 30, m)
    y1 = rng.uniform(0, h - 30, m)
    return np.stack([x1, y1, x1 + rng.uniform(2, 30, m), y1 + rng.uniform(2, 30, m)], axis=1)


def synthetic_tables(
    rng: np.random.Generator, n: int, *, max_objects: int = 15, max_steps: int = 3
) -> tuple[GoldTable, PredictionTable]:
    """A random gold table of ``n`` instances and an aligned, partly right prediction table."""
    n_obj = rng.integers(3, max_objects + 1, n)
    n_st = rng.integers(1, max_steps + 1, n)
    obj_off = offsets_from_lengths(n_obj)
    o = int(obj_off[-1])
    step_inst = np.repeat(np.arange(n), n_st)
    t = len(step_inst)
    subjects = rng.integers(0, n_obj[step_inst])
    references = (subjects + rng.integers(1, n_obj[step_inst])) % n_obj[step_inst]
    actions = rng.integers(0, 3, t)
    initial = _random_boxes(rng, o)
    final = initial.copy()
    final[obj_off[step_inst] + subjects] = _random_boxes(rng, t)
    sb_rows = int((n_st * n_obj).sum())
    step_boxes = _random_boxes(rng, sb_rows)
    cats = pd.DataFrame({
        "steps": n_st, "objects": n_obj,
        "relational": rng.random(n) < 0.5, "relation_needed": rng.random(n) < 0.2,
        "phrasing": rng.choice(["simple", "complex", "compound"], n),
        "template": rng.choice([f"T{i:02d}" for i in range(1, 21)], n),
    })
    gold = GoldTable.build(
        ids=[f"s-{i:07d}" for i in range(n)], n_objects=n_obj, n_steps=n_st,
        initial_boxes=initial, final_boxes=final,
        final_positions=rng.uniform(-0.3, 0.3, (o, 3)), actions=actions, subjects=subjects,
        references=references, step_boxes=step_boxes, image_size=np.tile([320, 240], (n, 1)),
        categories=cats, split=SPLIT,
    )
    # Predictions: a mix of exact, jittered and missing.
    present = rng.random(n) < 0.95
    jitter = rng.normal(0, 4, (o, 4)) * (rng.random(o) < 0.5)[:, None]
    boxes = final + jitter
    boxes[:, 2] = np.maximum(boxes[:, 2], boxes[:, 0])
    boxes[:, 3] = np.maximum(boxes[:, 3], boxes[:, 1])
    boxes = np.clip(boxes, 0, [320, 240, 320, 240])
    boxes[~present[gold.obj_instance]] = 0.0
    pred_len = np.where(rng.random(n) < 0.8, n_st, rng.integers(0, max_steps + 1, n))
    pred_len = np.where(present, pred_len, 0)
    p_off = offsets_from_lengths(pred_len)
    p_inst = np.repeat(np.arange(n), pred_len)
    p_k = np.arange(len(p_inst)) - p_off[p_inst]
    gold_t = gold.step_offsets[p_inst] + np.minimum(p_k, n_st[p_inst] - 1)
    p_subj = np.where(rng.random(len(p_inst)) < 0.8, subjects[gold_t], rng.integers(0, n_obj[p_inst]))
    p_ref = np.where(rng.random(len(p_inst)) < 0.8, references[gold_t], rng.integers(0, n_obj[p_inst]))
    p_act = np.where(rng.random(len(p_inst)) < 0.9, actions[gold_t], rng.integers(0, 3, len(p_inst)))
    has_pos = present & (rng.random(n) < 0.5)
    positions = np.where(
        has_pos[gold.obj_instance][:, None],
        gold.final_positions + rng.normal(0, 0.01, (o, 3)),
        np.nan,
    )
    pick = np.where((present & (rng.random(n) < 0.5))[:, None], rng.uniform(0, 240, (n, 2)), np.nan)
    place = np.where((present & (rng.random(n) < 0.5))[:, None], rng.uniform(0, 240, (n, 2)), np.nan)
    has_sb = present & (rng.random(n) < 0.7)
    sb_inst = np.repeat(np.arange(n), n_st * n_obj)
    pred_sb = np.where(has_sb[sb_inst][:, None], step_boxes + rng.normal(0, 2, (sb_rows, 4)), 0.0)
    pred_sb[:, 2:] = np.maximum(pred_sb[:, 2:], pred_sb[:, :2])
    pred_sb = np.clip(pred_sb, 0, [320, 240, 320, 240])
    table = PredictionTable(
        header=HEADER, source="<synthetic>", present=present,
        line=np.where(present, np.arange(n) + 2, -1), boxes=boxes,
        has_step_boxes=has_sb, step_boxes=pred_sb,
        has_program=present, program_offsets=p_off, actions=p_act.astype(np.int8),
        subjects=p_subj, references=p_ref, pick=pick, place=place,
        has_positions=has_pos, positions=positions,
        counts={"instances": n, "predicted": int(present.sum())},
    )
    return gold, table


# -- an independent per-instance implementation ---------------------------------------------
def _iou(a: Sequence[float], b: Sequence[float]) -> float:
    iw = min(a[2], b[2]) - max(a[0], b[0])
    ih = min(a[3], b[3]) - max(a[1], b[1])
    inter = max(iw, 0.0) * max(ih, 0.0)
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    if union <= 0:
        return 1.0 if list(a) == list(b) else 0.0
    return inter / union


def loop_scores(gold: GoldTable, pred: PredictionTable) -> dict[str, list[float]]:
    """IoU, IoU-M, success (2D), program exact and subject/all for each instance, in Python."""
    g_final = gold.final_boxes.tolist()
    p_boxes = pred.boxes.tolist()
    moved = gold.moved.tolist()
    g_off = gold.obj_offsets.tolist()
    s_off = gold.step_offsets.tolist()
    p_off = pred.program_offsets.tolist()
    g_steps = list(zip(gold.actions.tolist(), gold.subjects.tolist(), gold.references.tolist(),
                       strict=True))
    p_steps = list(zip(pred.actions.tolist(), pred.subjects.tolist(), pred.references.tolist(),
                       strict=True))
    present = pred.present.tolist()
    has_prog = pred.has_program.tolist()
    out: dict[str, list[float]] = {k: [] for k in ("iou", "iou_m", "success_2d", "program_exact",
                                                    "subject_all_steps")}
    for i in range(len(gold.ids)):
        if not present[i]:
            n_moved = sum(moved[g_off[i]:g_off[i + 1]])
            out["iou"].append(0.0)
            out["iou_m"].append(0.0 if n_moved else float("nan"))
            out["success_2d"].append(0.0)
            out["program_exact"].append(0.0)
            out["subject_all_steps"].append(0.0)
            continue
        ious = [_iou(p_boxes[j], g_final[j]) for j in range(g_off[i], g_off[i + 1])]
        mv = [x for x, m in zip(ious, moved[g_off[i]:g_off[i + 1]], strict=True) if m]
        out["iou"].append(sum(ious) / len(ious))
        out["iou_m"].append(sum(mv) / len(mv) if mv else float("nan"))
        out["success_2d"].append(float(all(x >= 0.5 for x in mv)))
        gs = g_steps[s_off[i]:s_off[i + 1]]
        ps = p_steps[p_off[i]:p_off[i + 1]] if has_prog[i] else None
        same = ps is not None and len(ps) == len(gs)
        out["program_exact"].append(float(same and all(
            a == b for a, b in zip(gs, ps or [], strict=False))))
        out["subject_all_steps"].append(float(same and all(
            a[1] == b[1] for a, b in zip(gs, ps or [], strict=False))))
    return out


def write_table_jsonl(gold: GoldTable, pred: PredictionTable, path: Any) -> None:
    """Write a prediction table as a JSON Lines predictions file (for end-to-end timing)."""
    import json

    p_off = pred.program_offsets
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(json.dumps({"header": HEADER.to_dict()}) + "\n")
        boxes = np.round(pred.boxes, 3).tolist()
        sb = np.round(pred.step_boxes, 3).tolist()
        acts = [ACTION_NAMES[a] for a in pred.actions.tolist()]
        subs, refs = pred.subjects.tolist(), pred.references.tolist()
        for i in np.flatnonzero(pred.present).tolist():
            o0, o1 = int(gold.obj_offsets[i]), int(gold.obj_offsets[i + 1])
            n = o1 - o0
            rec: dict[str, Any] = {"id": gold.ids[i], "boxes": boxes[o0:o1]}
            rec["program"] = [[acts[t], subs[t], refs[t]] for t in range(p_off[i], p_off[i + 1])]
            if pred.has_step_boxes[i]:
                s0, s1 = int(gold.stepbox_offsets[i]), int(gold.stepbox_offsets[i + 1])
                rows = sb[s0:s1]
                rec["step_boxes"] = [rows[k:k + n] for k in range(0, len(rows), n)]
            fh.write(json.dumps(rec, separators=(",", ":")) + "\n")


def write_table_parquet(gold: GoldTable, pred: PredictionTable, path: Any) -> None:
    """The same predictions as :func:`write_table_jsonl`, as a Parquet predictions file."""
    from nsrmp_bench.scoring.submission import write_submission

    p_off = pred.program_offsets
    boxes = np.round(pred.boxes, 3)
    sb = np.round(pred.step_boxes, 3)
    acts = [ACTION_NAMES[a] for a in pred.actions.tolist()]
    subs, refs = pred.subjects.tolist(), pred.references.tolist()

    def one(i: int) -> Prediction:
        o0, o1 = int(gold.obj_offsets[i]), int(gold.obj_offsets[i + 1])
        steps = [(acts[t], subs[t], refs[t]) for t in range(p_off[i], p_off[i + 1])]
        fields: dict[str, Any] = {"program": steps}
        if pred.has_step_boxes[i]:
            s0, s1 = int(gold.stepbox_offsets[i]), int(gold.stepbox_offsets[i + 1])
            fields["step_boxes"] = sb[s0:s1].reshape(-1, o1 - o0, 4)
        return prediction(gold.ids[i], boxes[o0:o1], **fields)

    write_submission(path, HEADER, (one(i) for i in np.flatnonzero(pred.present).tolist()))


ACTION_NAMES = ("top", "left", "right")
