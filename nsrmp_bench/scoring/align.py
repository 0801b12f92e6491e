"""Matching a checked submission to a split's instances: the checks that need the gold.

:func:`align` runs the named checks below in order and refuses (with one
:class:`~nsrmp_bench.errors.SubmissionError` naming every line) a submission for another
split (:func:`check_split`), ids that are not in the split (:func:`check_ids`), wrong
object counts (:func:`check_object_counts`), and boxes or points outside the image
(:func:`check_box_bounds`, :func:`check_point_bounds`). Coordinates at most
``clip_tolerance`` pixels outside the image are clipped onto it and counted (gold amodal
boxes are clipped the same way); step boxes for another number of steps are ignored and
counted (:func:`other_step_count`). Instances without a line are *missing*: they stay in
the table, flagged, and score zero (:func:`lay_out`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from itertools import repeat

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidArgument, SubmissionError
from nsrmp_bench.scoring.detected import resolve_detections
from nsrmp_bench.scoring.gold import GoldTable
from nsrmp_bench.scoring.matching import MATCH_IOU
from nsrmp_bench.scoring.ragged import copy_rows, gather_rows, offsets_from_lengths, row_ids
from nsrmp_bench.scoring.submission import Submission, SubmissionHeader
from nsrmp_bench.scoring.validate import MAX_SHOWN, Problems

__all__ = [
    "CLIP_TOLERANCE",
    "CheckedRecords",
    "Matching",
    "PredictionTable",
    "align",
    "check_box_bounds",
    "check_ids",
    "check_object_counts",
    "check_point_bounds",
    "check_split",
    "lay_out",
    "other_step_count",
    "split_matches",
]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
B = NDArray[np.bool_]

CLIP_TOLERANCE = 1.0
"""Pixels a coordinate may lie outside the image and still be clipped (with a warning)."""


@dataclass(frozen=True, eq=False)
class PredictionTable:
    """A submission laid out like its :class:`GoldTable`: same instances, objects, steps."""

    header: SubmissionHeader
    source: str
    present: B  # (I,) the instance has a line
    line: I64  # (I,) its line (row) number, -1 if missing
    boxes: F64  # (O, 4), zeros where missing
    has_step_boxes: B  # (I,)
    step_boxes: F64  # (P, 4), laid out like gold.step_boxes; zeros where absent
    has_program: B  # (I,)
    program_offsets: I64  # (I+1,)
    actions: NDArray[np.int8]  # (U,)
    subjects: I64  # (U,)
    references: I64  # (U,)
    pick: F64  # (I, 2), NaN where absent
    place: F64  # (I, 2), NaN where absent
    has_positions: B  # (I,)
    positions: F64  # (O, 3), NaN where absent
    counts: dict[str, int] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    object_matched: B | None = None  # (O,) False: a gold object no detection matched
    abstain: NDArray[np.int8] | None = None  # (I,) 0 none, 1 no action, 2 not feasible

    @property
    def abstain_codes(self) -> NDArray[np.int8]:
        """(I,) each instance's abstain code (``ABSTAIN_CODES``; 0 where none or missing)."""
        if self.abstain is None:
            return np.zeros(len(self.present), dtype=np.int8)
        return self.abstain

    @property
    def n_program_steps(self) -> I64:
        """Predicted steps per instance (0 where no program)."""
        out: I64 = np.diff(self.program_offsets)
        return out


def split_matches(declared: str, data: str) -> bool:
    """Whether a header's split id names the data's: the same id, or the split of the data's
    part (``paper-v2`` for data ``paper-v2/test``; the ids then tell the parts apart)."""
    return declared == data or data.startswith(declared + "/")


def _bounds(
    arr: F64,
    width: F64,
    height: F64,
    tol: float,
) -> tuple[B, B]:
    """Per row: outside the image by more than ``tol``; and outside it at all.

    A row ``x1, y1, x2, y2`` is outside when its least coordinate is below 0 or its
    greatest x (y) beyond the width (height); NaN coordinates take no part.
    """
    low = np.fmin(np.fmin(arr[:, 0], arr[:, 1]), np.fmin(arr[:, 2], arr[:, 3]))
    x = np.fmax(arr[:, 0], arr[:, 2])
    y = np.fmax(arr[:, 1], arr[:, 3])
    far: B = (low < -tol) | (x > width + tol) | (y > height + tol)
    out: B = (low < 0) | (x > width) | (y > height)
    return far, out


@dataclass(frozen=True, eq=False)
class Matching:
    """A submission's records against the gold: which instance each record is for."""

    sub: Submission
    gold: GoldTable
    gold_row: I64  # (R,) the gold instance of each record, -1 for an id not in the split

    @classmethod
    def of(cls, sub: Submission, gold: GoldTable) -> Matching:
        """Look every record's id up in ``gold``."""
        rows = np.fromiter(map(gold.index.get, sub.ids, repeat(-1)), dtype=np.int64,
                           count=len(sub.ids))
        return cls(sub, gold, rows)

    @property
    def known(self) -> B:
        """(R,) the record's id is an instance of the split."""
        out: B = self.gold_row >= 0
        return out

    @property
    def safe_row(self) -> I64:
        """(R,) the gold instance, 0 for unknown ids (index with :attr:`known`)."""
        out: I64 = np.where(self.known, self.gold_row, 0)
        return out

    @property
    def image_size(self) -> F64:
        """(R, 2) width and height of each record's instance."""
        out: F64 = self.gold.image_size[self.safe_row].astype(np.float64)
        return out


def check_split(sub: Submission, gold: GoldTable, problems: Problems,
                warnings: list[str]) -> None:
    """Refuse a file whose header names another split (at once, with what else was found);
    warn when the data records no split id to check against."""
    if gold.split is None:
        warnings.append(
            f"the data records no split id, so the header's split {sub.header.split!r} was "
            "not checked against it"
        )
        return
    if not split_matches(sub.header.split, gold.split):
        msg = (
            f"{sub.source}: the header says split {sub.header.split!r} but the data is split "
            f"{gold.split!r}; score the file against {sub.header.split!r} data, or predict on "
            f"{gold.split!r} and write its id in the header"
        )
        if problems.count:
            msg += "\n" + problems.message()
        raise SubmissionError(msg)


def check_ids(m: Matching, unknown_ids: str, problems: Problems,
              warnings: list[str]) -> I64:
    """Records whose id is not in the split: problems, or (``"warn"``) ignored and listed."""
    sub = m.sub
    unknown: I64 = np.flatnonzero(~m.known)
    split_name = m.gold.split or "the data"
    if not len(unknown):
        return unknown
    if unknown_ids == "error":
        for r in unknown[:MAX_SHOWN].tolist():
            problems.add(
                sub.where(r),
                f"id {sub.ids[r]!r} is not an instance of {split_name}; remove the line "
                "(or score with unknown ids ignored: --allow-unknown-ids)",
            )
        problems.count += len(unknown) - min(len(unknown), MAX_SHOWN)
    else:
        shown = ", ".join(sub.where(r) for r in unknown[:10].tolist())
        more = f" and {len(unknown) - 10} more" if len(unknown) > 10 else ""
        warnings.append(
            f"{len(unknown)} line(s) with ids not in {split_name} were ignored: {shown}{more}"
        )
    return unknown


def check_object_counts(m: Matching, problems: Problems) -> B:
    """Records with one box per object of their instance (the others are problems)."""
    sub = m.sub
    n_obj_gold = m.gold.n_objects[m.safe_row]
    bad_count = m.known & (sub.n_objects != n_obj_gold)
    for r in np.flatnonzero(bad_count)[:MAX_SHOWN].tolist():
        problems.add(
            sub.where(r),
            f"'boxes' has {int(sub.n_objects[r])} boxes but instance {sub.ids[r]!r} has "
            f"{int(n_obj_gold[r])} objects; give one box per object, in the episode's "
            "object order",
        )
    problems.count += max(0, int(bad_count.sum()) - MAX_SHOWN)
    ok: B = m.known & ~bad_count
    return ok


def other_step_count(m: Matching, ok: B) -> B:
    """Records whose step boxes are for another number of steps than the gold's.

    A model that split the instruction differently cannot be compared step by step: its
    step boxes are ignored, so the per-step IoU-M counts those steps as failures, and
    counted; the file still scores.
    """
    sub = m.sub
    out: B = ok & sub.has_step_boxes & (sub.n_step_states != m.gold.n_steps[m.safe_row])
    return out


def check_box_bounds(m: Matching, ok: B, name: str, arr: F64, offsets: I64,
                     per_state: I64 | None, tol: float, problems: Problems) -> int:
    """Boxes of ``ok`` records far outside the image are problems; boxes at most ``tol``
    pixels outside are clipped onto it in ``arr`` (in place). Returns how many were."""
    sub = m.sub
    size = m.image_size
    rec = row_ids(offsets)
    rows_ok = ok[rec]
    far, out = _bounds(arr, size[rec, 0], size[rec, 1], tol)
    far &= rows_ok
    for row in np.flatnonzero(far)[:MAX_SHOWN].tolist():
        r = int(rec[row])
        k = row - int(offsets[r])
        path = f"{name}[{k}]"
        if per_state is not None:
            path = f"{name}[{k // int(per_state[r])}][{k % int(per_state[r])}]"
        w, h = (int(v) for v in size[r])
        problems.add(
            sub.where(r),
            f"{path} = {[float(v) for v in arr[row]]} lies outside the {w}x{h} image; "
            f"boxes are pixel [x1, y1, x2, y2] with 0 <= x <= {w} and 0 <= y <= {h} "
            "(scale normalised coordinates to pixels; clip boxes to the image)",
        )
    problems.count += max(0, int(far.sum()) - MAX_SHOWN)
    fix = out & rows_ok & ~far
    if fix.any():
        wx = size[rec[fix], 0][:, None]
        hy = size[rec[fix], 1][:, None]
        arr[fix, 0::2] = np.clip(arr[fix, 0::2], 0.0, wx)
        arr[fix, 1::2] = np.clip(arr[fix, 1::2], 0.0, hy)
    return int(fix.sum())


def check_point_bounds(m: Matching, ok: B, name: str, pts: F64, tol: float,
                       problems: Problems) -> int:
    """Like :func:`check_box_bounds` for one pixel point per record (``pick``, ``place``;
    NaN where absent)."""
    sub = m.sub
    size = m.image_size
    rows = ok & ~np.isnan(pts[:, 0])
    two = np.concatenate([pts, pts], axis=1)
    far, out = _bounds(np.nan_to_num(two), size[:, 0], size[:, 1], tol)
    far &= rows
    for r in np.flatnonzero(far)[:MAX_SHOWN].tolist():
        w, h = (int(v) for v in size[r])
        problems.add(
            sub.where(r),
            f"{name} = {[float(v) for v in pts[r]]} lies outside the {w}x{h} image; it is "
            "a pixel location [x, y]",
        )
    problems.count += max(0, int(far.sum()) - MAX_SHOWN)
    fix = out & rows & ~far
    if fix.any():
        pts[fix, 0] = np.clip(pts[fix, 0], 0.0, size[fix, 0])
        pts[fix, 1] = np.clip(pts[fix, 1], 0.0, size[fix, 1])
    return int(fix.sum())


@dataclass(frozen=True, eq=False)
class CheckedRecords:
    """What the checks leave: which records are used, and their (clipped) arrays."""

    ok: B  # (R,) records laid out
    use_step_boxes: B  # (R,)
    other_step_count: B  # (R,)
    boxes: F64
    step_boxes: F64
    pick: F64
    place: F64
    unknown: int
    clipped: int


def lay_out(m: Matching, checked: CheckedRecords, warnings: list[str]) -> PredictionTable:
    """The checked records in gold order; instances without one are missing."""
    sub, gold = m.sub, m.gold
    n_inst = gold.n_instances
    recs = np.flatnonzero(checked.ok)
    g_of = m.gold_row[recs]
    order = np.argsort(g_of, kind="stable")
    recs, g_of = recs[order], g_of[order]
    present = np.zeros(n_inst, dtype=bool)
    present[g_of] = True
    line = np.full(n_inst, -1, dtype=np.int64)
    line[g_of] = sub.lines[recs]

    # np.zeros, not zeros_like: fresh zero pages instead of writing every zero first
    pred_boxes = np.zeros(gold.final_boxes.shape, gold.final_boxes.dtype)
    src, _ = gather_rows(sub.obj_offsets, recs)
    dst, _ = gather_rows(gold.obj_offsets, g_of)
    copy_rows(pred_boxes, dst, checked.boxes, src)
    object_matched = None
    if sub.object_matched is not None:
        object_matched = np.ones(len(gold.final_boxes), dtype=bool)
        object_matched[dst] = sub.object_matched[src]

    pred_pos = np.full(gold.final_positions.shape, np.nan, gold.final_positions.dtype)
    copy_rows(pred_pos, dst, sub.positions, src)
    has_pos = np.zeros(n_inst, dtype=bool)
    has_pos[g_of] = sub.has_positions[recs]

    use_sb = checked.use_step_boxes
    has_sb = np.zeros(n_inst, dtype=bool)
    has_sb[g_of] = use_sb[recs]
    pred_sb = np.zeros(gold.step_boxes.shape, gold.step_boxes.dtype)
    sb_recs = recs[use_sb[recs]]
    src, _ = gather_rows(sub.stepbox_offsets, sb_recs)
    dst, _ = gather_rows(gold.stepbox_offsets, m.gold_row[sb_recs])
    copy_rows(pred_sb, dst, checked.step_boxes, src)

    has_prog = np.zeros(n_inst, dtype=bool)
    has_prog[g_of] = sub.has_program[recs]
    prog_len = np.zeros(n_inst, dtype=np.int64)
    prog_len[g_of] = np.diff(sub.program_offsets)[recs]
    src, _ = gather_rows(sub.program_offsets, recs)
    prog_off = offsets_from_lengths(prog_len)

    pick_g = np.full((n_inst, 2), np.nan)
    pick_g[g_of] = checked.pick[recs]
    place_g = np.full((n_inst, 2), np.nan)
    place_g[g_of] = checked.place[recs]
    abstain_g = np.zeros(n_inst, dtype=np.int8)
    abstain_g[g_of] = sub.abstain_codes[recs]

    counts = {
        "instances": n_inst,
        "lines": len(sub),
        "predicted": len(recs),
        "missing": n_inst - len(recs),
        "unknown_ids_ignored": checked.unknown,
        "clipped": checked.clipped,
        "with_program": int(has_prog.sum()),
        "with_step_boxes": int(has_sb.sum()),
        "step_boxes_other_step_count": int(checked.other_step_count[recs].sum()),
        "with_positions": int(has_pos.sum()),
        "with_pick": int((present & ~np.isnan(pick_g[:, 0])).sum()),
        "with_place": int((present & ~np.isnan(place_g[:, 0])).sum()),
    }
    if abstain_g.any():  # counted only where used: a file without abstain reads as before
        counts["abstained"] = int((abstain_g > 0).sum())
    if counts["missing"]:
        warnings.append(
            f"{counts['missing']} of {n_inst} instances have no prediction; they score zero "
            "on every metric"
        )
    return PredictionTable(
        header=sub.header,
        source=sub.source,
        present=present,
        line=line,
        boxes=pred_boxes,
        has_step_boxes=has_sb,
        step_boxes=pred_sb,
        has_program=has_prog,
        program_offsets=prog_off,
        actions=sub.actions[src],
        subjects=sub.subjects[src],
        references=sub.references[src],
        pick=pick_g,
        place=place_g,
        has_positions=has_pos,
        positions=pred_pos,
        counts=counts,
        warnings=tuple(warnings),
        object_matched=object_matched,
        abstain=abstain_g,
    )


def align(
    submission: Submission,
    gold: GoldTable,
    *,
    unknown_ids: str = "error",
    clip_tolerance: float = CLIP_TOLERANCE,
    pending: Problems | None = None,
) -> PredictionTable:
    """Lay ``submission`` out like ``gold``, or raise SubmissionError naming every problem.

    ``unknown_ids="warn"`` ignores lines whose id is not in the split, counting and
    listing them in the warnings instead of refusing the file. ``pending`` holds problems
    already found in the file (see ``read_submission_pending``); they are raised together
    with these.
    """
    if unknown_ids not in ("error", "warn"):
        msg = f"unknown_ids must be 'error' or 'warn', got {unknown_ids!r}"
        raise InvalidArgument(msg)
    sub = submission
    problems = pending if pending is not None else Problems(sub.source)
    warnings: list[str] = []
    check_split(sub, gold, problems, warnings)
    m = Matching.of(sub, gold)
    unknown = check_ids(m, unknown_ids, problems, warnings)
    detected: dict[str, int] = {}
    if sub.has_detections is not None and sub.detections is not None:
        # bounds are checked in the line's own (detection) order, before resolution
        det_ok = m.known & sub.has_detections
        dets, d_boxes, d_step = sub.detections.copy(), sub.boxes.copy(), sub.step_boxes.copy()
        clipped_det = sum((
            check_box_bounds(m, det_ok, "detections", dets, sub.obj_offsets, None,
                             clip_tolerance, problems),
            check_box_bounds(m, det_ok, "boxes", d_boxes, sub.obj_offsets, None,
                             clip_tolerance, problems),
            check_box_bounds(m, det_ok, "step_boxes", d_step, sub.stepbox_offsets,
                             sub.n_objects, clip_tolerance, problems)))
        sub = dataclasses.replace(sub, detections=dets, boxes=d_boxes, step_boxes=d_step)
        sub, detected = resolve_detections(sub, gold, m.known, m.gold_row)
        if clipped_det:
            warnings.append(f"{clipped_det} box(es) of lines with detections lay up to "
                            f"{clip_tolerance:g} px outside the image and were clipped onto it")
        m = Matching.of(sub, gold)
    ok = check_object_counts(m, problems)
    other = other_step_count(m, ok)
    boxes, step_boxes = sub.boxes.copy(), sub.step_boxes.copy()
    pick, place = sub.pick.copy(), sub.place.copy()
    clipped = (
        check_box_bounds(m, ok, "boxes", boxes, sub.obj_offsets, None, clip_tolerance,
                         problems)
        + check_box_bounds(m, ok, "step_boxes", step_boxes, sub.stepbox_offsets,
                           sub.n_objects, clip_tolerance, problems)
        + check_point_bounds(m, ok, "pick", pick, clip_tolerance, problems)
        + check_point_bounds(m, ok, "place", place, clip_tolerance, problems)
    )
    problems.raise_if_any()
    if clipped:
        warnings.append(
            f"{clipped} box(es) or point(s) lay up to {clip_tolerance:g} px outside the image "
            "and were clipped onto it"
        )
    checked = CheckedRecords(ok, sub.has_step_boxes & ~other, other, boxes, step_boxes, pick, place,
                       len(unknown), clipped)
    table = lay_out(m, checked, warnings)
    if detected:
        table.counts.update(detected)
        table = dataclasses.replace(table, warnings=(*table.warnings, (
            f"{detected['detected_lines']} line(s) predict on their own detections: "
            f"{detected['detected_objects_unmatched']} gold object(s) no detection matched "
            f"(IoU >= {MATCH_IOU:g}) score IoU 0; {detected['detections_unmatched']} "
            "detection(s) matched no gold object")))
    return table
