"""The detected-objects protocol: predictions made on a model's own detected objects.

A line may carry ``detections``: the model's detected initial objects, K boxes (pixel
xyxy in the initial image). Its ``boxes``, ``step_boxes``, ``positions`` and the program's
object indices are then per *detection* (K of them, in the order of ``detections``), not
per gold object. Before anything is scored, :func:`resolve_detections` matches each such
line's detections to the instance's gold initial boxes (Hungarian on IoU, a pair matches
at IoU >= :data:`~nsrmp_bench.scoring.matching.MATCH_IOU`) and rewrites the line in the
gold object order:

- a matched gold object takes its detection's boxes and position;
- an unmatched gold object (missed, or merged with another) takes empty boxes and no
  position: it scores IoU 0 and fails success; nothing is excluded;
- program indices map through the matching; a step naming an unmatched detection names
  no gold object (index -1) and so is wrong;
- a line without ``pick`` whose program has a first step gets the centre of that step's
  subject detection as its pick (what the model pointed at).

The counts say how many lines used the protocol and how many gold objects and detections
were matched.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.scoring.gold import GoldTable
from nsrmp_bench.scoring.matching import MATCH_IOU, hungarian_match
from nsrmp_bench.scoring.ragged import offsets_from_lengths
from nsrmp_bench.scoring.submission import Submission

__all__ = ["resolve_detections"]

F64 = NDArray[np.float64]


def resolve_detections(sub: Submission, gold: GoldTable, known: NDArray[np.bool_],
                       gold_row: NDArray[np.int64]) -> tuple[Submission, dict[str, int]]:
    """``sub`` with every known detected-objects line rewritten in gold object order, and
    the matching counts. Lines without ``detections`` are left as they are."""
    if sub.has_detections is None or not sub.has_detections.any():
        return sub, {}
    assert sub.detections is not None
    obj_off, sb_off, pg_off = sub.obj_offsets, sub.stepbox_offsets, sub.program_offsets
    nobj, boxes, sboxes, pos, matched_l = [], [], [], [], []
    acts, subj, refs, plen = [], [], [], []
    pick = sub.pick.copy()
    counts = {"detected_lines": 0, "detected_objects_matched": 0,
              "detected_objects_unmatched": 0, "detections_unmatched": 0}
    for r in range(len(sub)):
        o0, o1 = int(obj_off[r]), int(obj_off[r + 1])
        k = o1 - o0
        s_states = int(sub.n_step_states[r])
        b = sub.boxes[o0:o1]
        sb = sub.step_boxes[int(sb_off[r]):int(sb_off[r + 1])].reshape(s_states, k, 4)
        p = sub.positions[o0:o1]
        a = sub.actions[int(pg_off[r]):int(pg_off[r + 1])]
        s = sub.subjects[int(pg_off[r]):int(pg_off[r + 1])]
        f = sub.references[int(pg_off[r]):int(pg_off[r + 1])]
        if not (sub.has_detections[r] and known[r]):
            nobj.append(k)
            boxes.append(b)
            sboxes.append(sb.reshape(-1, 4))
            pos.append(p)
            matched_l.append(np.ones(k, dtype=bool))
            acts.append(a)
            subj.append(s)
            refs.append(f)
            plen.append(len(a))
            continue
        g = int(gold_row[r])
        g0, g1 = int(gold.obj_offsets[g]), int(gold.obj_offsets[g + 1])
        dets = sub.detections[o0:o1]
        match = hungarian_match(gold.initial_boxes[g0:g1], dets, MATCH_IOU)  # gold -> det
        hit = match >= 0
        n = g1 - g0
        inverse = np.full(k, -1, dtype=np.int64)
        inverse[match[hit]] = np.flatnonzero(hit)
        nb = np.zeros((n, 4))
        nb[hit] = b[match[hit]]
        nsb = np.zeros((s_states, n, 4))
        nsb[:, hit] = sb[:, match[hit]]
        npos = np.full((n, 3), np.nan)
        npos[hit] = p[match[hit]]
        if np.isnan(pick[r, 0]) and len(s):
            d = dets[int(s[0])]
            pick[r] = ((d[0] + d[2]) / 2, (d[1] + d[3]) / 2)
        nobj.append(n)
        boxes.append(nb)
        sboxes.append(nsb.reshape(-1, 4))
        pos.append(npos)
        matched_l.append(hit)
        acts.append(a)
        subj.append(inverse[s])
        refs.append(inverse[f])
        plen.append(len(a))
        counts["detected_lines"] += 1
        counts["detected_objects_matched"] += int(hit.sum())
        counts["detected_objects_unmatched"] += int((~hit).sum())
        counts["detections_unmatched"] += k - int(hit.sum())
    n_arr = np.asarray(nobj, dtype=np.int64)
    resolved = dataclasses.replace(
        sub,
        obj_offsets=offsets_from_lengths(n_arr),
        boxes=np.concatenate(boxes) if boxes else np.zeros((0, 4)),
        stepbox_offsets=offsets_from_lengths(sub.n_step_states * n_arr),
        step_boxes=np.concatenate(sboxes) if sboxes else np.zeros((0, 4)),
        positions=np.concatenate(pos) if pos else np.zeros((0, 3)),
        program_offsets=offsets_from_lengths(np.asarray(plen, dtype=np.int64)),
        actions=np.concatenate(acts).astype(np.int8) if acts else sub.actions,
        subjects=np.concatenate(subj).astype(np.int64) if subj else sub.subjects,
        references=np.concatenate(refs).astype(np.int64) if refs else sub.references,
        pick=pick,
        has_detections=np.zeros(len(sub), dtype=bool),
        detections=None,
        object_matched=np.concatenate(matched_l) if matched_l else np.zeros(0, dtype=bool),
    )
    return resolved, counts
