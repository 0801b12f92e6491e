"""Checking a predictions file line by line, and parsing it into a :class:`Submission`.

Every problem names its line (or Parquet row), the offending value, what was expected and
the fix; all problems of a file are gathered (the first :data:`MAX_SHOWN` are shown) and
raised together as one :class:`~nsrmp_bench.errors.SubmissionError`, so nothing is
scored from a file with a problem and no line is dropped silently.

Structure (types, lengths, keys, ids, programs) is checked per line in Python; numbers
(types, finiteness, ``x1 <= x2``) are checked vectorised over the whole file, falling back
to a per-line scan to name the culprit. Checks that need the split's instances (unknown
ids, object counts, image bounds) are in :mod:`nsrmp_bench.scoring.align`.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.errors import SubmissionError
from nsrmp_bench.scoring.ragged import offsets_from_lengths
from nsrmp_bench.scoring.submission import (
    ABSTAIN_CODES,
    ABSTAIN_VALUES,
    Prediction,
    Submission,
    SubmissionHeader,
)
from nsrmp_bench.scoring.version import (
    KNOWN_SCORERS,
    SCORER_ID,
    SUBMISSION_FORMAT,
    SUBMISSION_FORMAT_VERSION,
)
from nsrmp_bench.vocabulary import ACTIONS

__all__ = [
    "MAX_SHOWN",
    "RECORD_FIELDS",
    "Problems",
    "SubmissionParser",
    "parse_predictions",
    "parse_submission",
]

MAX_SHOWN = 20
"""Most problems listed in one error message (all are counted)."""

RECORD_FIELDS = ("id", "boxes", "step_boxes", "program", "pick", "place", "positions",
                 "detections", "abstain")
"""The fields a prediction line may have; ``id`` and ``boxes`` are required."""

_FIELD_SET = frozenset(RECORD_FIELDS)
_ACTION_CODE = {a: i for i, a in enumerate(ACTIONS)}
_MAX_INT = 2**53
_FIX = (
    "the format is documented in nsrmp_bench/scoring/submission.schema.json; check a file "
    "with `nsrmp-bench check-submission FILE --split ID`"
)


def _show(value: object, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _json_type(value: object) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int | float):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list):
        return "array"
    if isinstance(value, dict):
        return "object"
    return type(value).__name__


def _number_problem(value: object) -> str | None:
    """Why ``value`` is not an acceptable number, or None."""
    if isinstance(value, bool):
        return f"is {str(value).lower()}, a boolean, not a number"
    if isinstance(value, int):
        return None if abs(value) <= _MAX_INT else f"is {value}, too large for a coordinate"
    if isinstance(value, float):
        if math.isnan(value):
            return "is NaN; predictions must be finite numbers (predict a box, not NaN)"
        if math.isinf(value):
            return "is infinite; predictions must be finite numbers"
        return None
    return f"is a {_json_type(value)} ({_show(value, 30)}), not a number"


class Problems:
    """The problems found in one file: all counted, the first :data:`MAX_SHOWN` kept."""

    def __init__(self, source: str) -> None:
        self.source = source
        self.count = 0
        self.shown: list[tuple[int, str]] = []

    def add(self, where: str, text: str) -> None:
        """Record that ``where`` (e.g. ``line 4``) ``text`` (a sentence naming value and fix)."""
        self.count += 1
        if len(self.shown) < MAX_SHOWN:
            number = where.rsplit(" ", 1)[-1]
            order = int(number) if number.isdigit() else -1
            self.shown.append((order, f"{where}: {text}" if where else text))

    def __len__(self) -> int:
        return self.count

    def message(self) -> str:
        """The error message listing the problems."""
        head = (
            f"{self.source}: {self.count} problem{'s' if self.count != 1 else ''} in the "
            "predictions file; nothing was scored. Fix "
            + ("it" if self.count == 1 else "them")
            + ":"
        )
        lines = [head, *(f"  {s}" for _, s in sorted(self.shown, key=lambda item: item[0]))]
        if self.count > len(self.shown):
            lines.append(f"  ... and {self.count - len(self.shown)} more of the same kinds")
        lines.append(f"({_FIX})")
        return "\n".join(lines)

    def raise_if_any(self) -> None:
        """Raise one :class:`SubmissionError` listing every problem, if there is any."""
        if self.count:
            raise SubmissionError(self.message())


def _did_you_mean(word: str, options: Iterable[str]) -> str:
    close = difflib.get_close_matches(word, list(options), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


class SubmissionParser:
    """Feed it the header and then each line's parsed JSON; :meth:`finish` gives the table."""

    def __init__(self, source: str, *, line_label: str = "line") -> None:
        self.source = source
        self.label = line_label
        self.problems = Problems(source)
        self.header: SubmissionHeader | None = None
        self._header_seen = False
        self._seen: dict[str, int] = {}
        self._ids: list[str] = []
        self._lines: list[int] = []
        self._nobj: list[int] = []
        self._boxes: list[Any] = []
        self._nstates: list[int] = []
        self._has_sb: list[bool] = []
        self._step_boxes: list[Any] = []
        self._prog_len: list[int] = []
        self._has_prog: list[bool] = []
        self._steps: list[tuple[int, int, int]] = []
        self._pick: list[Any] = []
        self._place: list[Any] = []
        self._has_pos: list[bool] = []
        self._positions: list[Any] = []
        self._has_det: list[bool] = []
        self._detections: list[Any] = []
        self._abstain: list[int] = []
        self._raw: list[dict[str, Any]] = []

    def where(self, lineno: int) -> str:
        """``line N`` or ``row N``."""
        return f"{self.label} {lineno}"

    def problem(self, lineno: int | None, text: str) -> None:
        """Record a problem at a line (or for the whole file when ``lineno`` is None)."""
        self.problems.add("" if lineno is None else self.where(lineno), text)

    # -- the header -----------------------------------------------------------------------
    def parse_header(self, lineno: int | None, obj: object) -> None:
        """Check the header line; a line that is a prediction is also parsed as one."""
        self._header_seen = True
        example = (
            f'{{"header": {{"format": "{SUBMISSION_FORMAT}", "format_version": '
            f'"{SUBMISSION_FORMAT_VERSION}", "split": "SPLIT-vN", "scorer": "{SCORER_ID}"}}}}'
        )
        if not isinstance(obj, dict) or "header" not in obj:
            got = "a prediction" if isinstance(obj, dict) and "id" in obj else _json_type(obj)
            self.problem(
                lineno,
                f"the first line must be the header, but it is {got}; add a first line "
                f"like {example}",
            )
            if lineno is not None and isinstance(obj, dict) and "id" in obj:
                self.parse_record(lineno, obj, deep=True)
            return
        if len(obj) != 1:
            others = sorted(k for k in obj if k != "header")
            self.problem(lineno, f"the header line has extra keys {others}; it holds only 'header'")
        h = obj["header"]
        if not isinstance(h, dict):
            self.problem(lineno, f"'header' must be an object like {example}, got {_show(h)}")
            return
        ok = True
        for key in ("format", "format_version", "split", "scorer"):
            value = h.get(key)
            if not isinstance(value, str) or not value:
                self.problem(
                    lineno,
                    f"header field {key!r} must be a non-empty string, got {_show(value)}; "
                    f"a header looks like {example}",
                )
                ok = False
        if not ok:
            return
        if h["format"] != SUBMISSION_FORMAT:
            self.problem(
                lineno,
                f"header format is {h['format']!r}; a predictions file has format "
                f"{SUBMISSION_FORMAT!r}",
            )
            ok = False
        major = str(h["format_version"]).split(".")[0]
        if major != SUBMISSION_FORMAT_VERSION.split(".")[0]:
            self.problem(
                lineno,
                f"header format_version is {h['format_version']!r}; this reader reads "
                f"version {SUBMISSION_FORMAT_VERSION.split('.')[0]}.x "
                f"(current {SUBMISSION_FORMAT_VERSION}); rewrite the file in that format or "
                "use the nsrmp-bench release that matches it",
            )
            ok = False
        if h["scorer"] not in KNOWN_SCORERS:
            self.problem(
                lineno,
                f"header scorer is {h['scorer']!r}, which this nsrmp-bench does not know; it "
                f"scores {list(KNOWN_SCORERS)}: write the file for {SCORER_ID!r} or install "
                "the nsrmp-bench release that provides the other scorer",
            )
            ok = False
        model = h.get("model")
        if model is not None and not isinstance(model, str):
            self.problem(lineno, f"header field 'model' must be a string, got {_show(model)}")
            ok = False
        if ok:
            extra = {
                k: v
                for k, v in h.items()
                if k not in ("format", "format_version", "split", "scorer", "model")
            }
            self.header = SubmissionHeader(
                split=h["split"],
                scorer=h["scorer"],
                model=model,
                format=h["format"],
                format_version=h["format_version"],
                extra=extra,
            )

    # -- one prediction -------------------------------------------------------------------
    def _box_list(
        self, lineno: int, name: str, value: object, width: int, n: int | None, items: bool = True
    ) -> int:
        """Check a list of boxes (width 4) or points (width 3); its length, or -1.

        Without ``items`` only the list and its length are checked here; the items are
        checked vectorised for the whole file (see :meth:`_array`).
        """
        what = "[x1, y1, x2, y2] boxes" if width == 4 else "[x, y, z] positions"
        if not isinstance(value, list):
            self.problem(
                lineno,
                f"{name!r} must be a list of {what}, one per object, got a "
                f"{_json_type(value)} {_show(value, 40)}",
            )
            return -1
        if n is None and not value:
            self.problem(lineno, f"{name!r} is empty; give one box per object of the episode")
            return -1
        if n is not None and len(value) != n:
            self.problem(
                lineno,
                f"{name!r} has {len(value)} entries but 'boxes' has {n}; give one per object, "
                "in the episode's object order",
            )
            return -1
        for k, item in enumerate(value if items else ()):
            if not isinstance(item, list) or len(item) != width:
                self.problem(
                    lineno,
                    f"{name}[{k}] must be a list of {width} numbers "
                    f"({what[1:].split(']')[0]}), got {_show(item, 40)}",
                )
                return -1
        return len(value)

    def _numbers(self, lineno: int, name: str, value: object) -> bool:
        """Scan nested lists for a value that is not a finite number; report the first."""
        stack: list[tuple[str, Any]] = [(name, value)]
        while stack:
            path, v = stack.pop()
            if isinstance(v, list):
                stack.extend((f"{path}[{i}]", x) for i, x in reversed(list(enumerate(v))))
                continue
            why = _number_problem(v)
            if why is not None:
                self.problem(lineno, f"{path} {why}")
                return False
        return True

    def _point(self, lineno: int, name: str, value: object) -> tuple[float, float] | None:
        if not isinstance(value, list) or len(value) != 2:
            self.problem(
                lineno,
                f"{name!r} must be a pixel location [x, y], got {_show(value, 40)}; "
                "leave it out (or null) if you have none",
            )
            return None
        for i, v in enumerate(value):
            why = _number_problem(v)
            if why is not None:
                self.problem(lineno, f"{name}[{i}] {why}")
                return None
        return (float(value[0]), float(value[1]))

    def _program(self, lineno: int, value: object, n: int) -> list[tuple[int, int, int]] | None:
        if not isinstance(value, list):
            self.problem(
                lineno,
                f"'program' must be a list of [action, subject, reference] steps, got a "
                f"{_json_type(value)}; use [] for no steps or leave it out",
            )
            return None
        codes = _ACTION_CODE
        fast: list[tuple[int, int, int]] = []
        try:  # fast path: every step well formed
            for a, s, r in value:
                if type(s) is not int or type(r) is not int or not (0 <= s < n and 0 <= r < n):
                    break
                fast.append((codes[a], s, r))
            else:
                return fast
        except (KeyError, TypeError, ValueError):
            pass
        out: list[tuple[int, int, int]] = []
        for k, step in enumerate(value):
            if not isinstance(step, list) or len(step) != 3:
                self.problem(
                    lineno,
                    f"program[{k}] must be [action, subject, reference], e.g. [\"top\", 2, 0], "
                    f"got {_show(step, 40)}",
                )
                return None
            action, subject, reference = step
            if not isinstance(action, str) or action not in _ACTION_CODE:
                self.problem(
                    lineno,
                    f"program[{k}] action {_show(action, 30)} is not one of {list(ACTIONS)}",
                )
                return None
            for role, idx in (("subject", subject), ("reference", reference)):
                if isinstance(idx, bool) or not isinstance(idx, int) or not 0 <= idx < n:
                    self.problem(
                        lineno,
                        f"program[{k}] {role} {_show(idx, 30)} must be an object index "
                        f"0..{n - 1} (the episode's object order, as in 'boxes')",
                    )
                    return None
            out.append((_ACTION_CODE[action], subject, reference))
        return out  # pragma: no cover - the fast path accepts every valid program

    def parse_record(self, lineno: int, obj: object, *, deep: bool = False) -> None:
        """Check one prediction; a good one is kept, a bad one recorded as a problem.

        ``deep`` scans every number's type in Python (needed where a boolean could hide
        among numbers; otherwise types are checked vectorised in :meth:`finish`).
        """
        if not isinstance(obj, dict):
            self.problem(
                lineno,
                f"is a JSON {_json_type(obj)}; each line after the header must be an object "
                'like {"id": "...", "boxes": [[x1, y1, x2, y2], ...]}',
            )
            return
        if "header" in obj:
            self.problem(lineno, "is a second header; a file has one header, on its first line")
            return
        unknown = [k for k in obj if k not in _FIELD_SET] if obj.keys() - _FIELD_SET else []
        if unknown:
            hint = _did_you_mean(str(unknown[0]), RECORD_FIELDS)
            self.problem(
                lineno,
                f"unknown field{'s' if len(unknown) > 1 else ''} {unknown}{hint}; a prediction "
                f"has only {list(RECORD_FIELDS)}",
            )
            return
        rid = obj.get("id")
        if not isinstance(rid, str) or not rid:
            self.problem(
                lineno, f"'id' must be the instance id, a non-empty string; got {_show(rid, 40)}"
            )
            return
        if rid in self._seen:
            self.problem(
                lineno,
                f"id {rid!r} was already given on {self.where(self._seen[rid])}; give each "
                "instance once (remove one of the two lines)",
            )
            return
        self._seen[rid] = lineno
        boxes = obj.get("boxes")
        if boxes is None:
            self.problem(
                lineno,
                "'boxes' is missing; every prediction needs the final [x1, y1, x2, y2] box of "
                "each object (leave the instance out to score it as missing)",
            )
            return
        detections = obj.get("detections")
        n_det = None
        if detections is not None:  # the detected-objects protocol: boxes per detection
            size = len(detections) if isinstance(detections, list) else None
            n_det = self._box_list(lineno, "detections", detections, 4, size, deep)
            if n_det < 0 or (deep and not self._numbers(lineno, "detections", detections)):
                return
        if n_det is not None and isinstance(boxes, list) and len(boxes) != n_det:
            self.problem(
                lineno,
                f"'boxes' has {len(boxes)} entries but 'detections' has {n_det}; with "
                "detections, give one final box per detection, in the order of 'detections'",
            )
            return
        n = self._box_list(lineno, "boxes", boxes, 4, n_det, deep)
        if n < 0 or (deep and not self._numbers(lineno, "boxes", boxes)):
            return
        step_boxes = obj.get("step_boxes")
        if step_boxes is not None:
            if not isinstance(step_boxes, list):
                self.problem(
                    lineno,
                    "'step_boxes' must be a list with the boxes after each step (a list of "
                    f"[x1, y1, x2, y2] per object), got a {_json_type(step_boxes)}",
                )
                return
            for k, state in enumerate(step_boxes):
                if self._box_list(lineno, f"step_boxes[{k}]", state, 4, n, deep) < 0:
                    return
            if deep and not self._numbers(lineno, "step_boxes", step_boxes):
                return
        positions = obj.get("positions")
        if positions is not None and (
            self._box_list(lineno, "positions", positions, 3, n, deep) < 0
            or (deep and not self._numbers(lineno, "positions", positions))
        ):
            return
        program = obj.get("program")
        steps = None if program is None else self._program(lineno, program, n)
        if program is not None and steps is None:
            return
        pick = place = None
        if obj.get("pick") is not None:
            pick = self._point(lineno, "pick", obj["pick"])
            if pick is None:
                return
        if obj.get("place") is not None:
            place = self._point(lineno, "place", obj["place"])
            if place is None:
                return
        abstain = obj.get("abstain")
        code = 0
        if abstain is not None:
            code = self._abstain_code(lineno, abstain, obj)
            if code < 0:
                return
        # Everything structural is fine: keep the record.
        self._abstain.append(code)
        self._ids.append(rid)
        self._lines.append(lineno)
        self._nobj.append(n)
        self._boxes.extend(boxes)
        self._raw.append(obj)
        self._has_sb.append(step_boxes is not None)
        if step_boxes is None:
            self._nstates.append(0)
        else:
            self._nstates.append(len(step_boxes))
            for state in step_boxes:
                self._step_boxes.extend(state)
        self._has_prog.append(steps is not None)
        self._prog_len.append(0 if steps is None else len(steps))
        if steps:
            self._steps.extend(steps)
        self._pick.append(pick)
        self._place.append(place)
        self._has_pos.append(positions is not None)
        if positions is not None:
            self._positions.extend(positions)
        self._has_det.append(detections is not None)
        if detections is not None:
            self._detections.extend(detections)

    def _abstain_code(self, lineno: int, value: object, obj: dict[str, Any]) -> int:
        """The code of a line's ``abstain`` value (1, 2), or -1 after recording the problem:
        an unknown value, or an abstention that also acts (program steps, step boxes, a
        pick or place location)."""
        if not isinstance(value, str) or value not in ABSTAIN_CODES:
            hint = _did_you_mean(value, ABSTAIN_VALUES) if isinstance(value, str) else ""
            self.problem(
                lineno,
                f"'abstain' is {_show(value, 40)}{hint}; it is one of {list(ABSTAIN_VALUES)}, "
                "or null (or left out) for a line that acts",
            )
            return -1
        program = obj.get("program")
        if program:
            self.problem(
                lineno,
                f"'abstain' is {value!r} but the line also has a program of {len(program)} "
                "step(s); a line that abstains does nothing: give 'program': [] (or leave it "
                "out), or drop 'abstain' to act",
            )
            return -1
        acting = [k for k in ("step_boxes", "pick", "place") if obj.get(k) is not None]
        if acting:
            self.problem(
                lineno,
                f"'abstain' is {value!r} but the line also gives {acting}, a trace of actions "
                "on an instance it declares abstained; leave them out (its 'boxes' are the "
                "objects' final boxes, where they stand), or drop 'abstain' to act",
            )
            return -1
        return ABSTAIN_CODES[value]

    # -- the whole file -------------------------------------------------------------------
    def _array(self, rows: list[Any], width: int, name: str) -> NDArray[np.float64]:
        """Rows of numbers as a float array; rows holding a non-number are reported and zeroed."""
        if not rows:
            return np.zeros((0, width))
        try:
            arr = np.array(rows)
        except (ValueError, TypeError, OverflowError):
            arr = None
        if (
            arr is None
            or arr.dtype.kind not in "if"
            or arr.shape != (len(rows), width)
            or (arr.dtype.kind == "i" and np.abs(arr).max() > _MAX_INT)
        ):
            self._locate_bad_items(name, width)
            out = np.zeros((len(rows), width))
            for i, row in enumerate(rows):
                if (
                    isinstance(row, list)
                    and len(row) == width
                    and all(_number_problem(v) is None for v in row)
                ):
                    out[i] = row
            return out
        return arr.astype(np.float64)

    def _locate_bad_items(self, name: str, width: int) -> None:
        """Report, line by line, the items of ``name`` that are not lists of numbers."""
        before = self.problems.count
        for lineno, obj in zip(self._lines, self._raw, strict=True):
            value = obj.get(name)
            if value is None:
                continue
            lists = list(enumerate(value)) if name == "step_boxes" else [(None, value)]
            for k, boxes in lists:
                path = name if k is None else f"{name}[{k}]"
                if self._box_list(lineno, path, boxes, width, None) < 0:
                    break
                if not self._numbers(lineno, path, boxes):
                    break
        if self.problems.count == before:  # pragma: no cover - defensive
            self.problem(None, f"some {name!r} values are not numbers; check the file's {name}")

    def _check_finite_ordered(
        self, arr: NDArray[np.float64], offsets: NDArray[np.int64], name: str, boxes: bool,
        per_state: NDArray[np.int64] | None = None,
    ) -> None:
        """Report non-finite values and (for boxes) x2 < x1 or y2 < y1, naming each line."""
        finite = np.asarray(np.isfinite(arr).all(axis=1), dtype=bool)
        bad_order: NDArray[np.bool_] = np.zeros(len(arr), dtype=bool)
        if boxes:
            with np.errstate(invalid="ignore"):
                bad_order = finite & ((arr[:, 2] < arr[:, 0]) | (arr[:, 3] < arr[:, 1]))
        bad = np.flatnonzero(~finite | bad_order)
        if not len(bad):
            return
        rec = np.searchsorted(offsets, bad, side="right") - 1
        shown = MAX_SHOWN * 2
        for row, r in zip(bad[:shown].tolist(), rec[:shown].tolist(), strict=True):
            k = row - int(offsets[r])
            if per_state is not None:
                n = int(per_state[r])
                path = f"{name}[{k // n}][{k % n}]"
            else:
                path = f"{name}[{k}]"
            value = [float(v) for v in arr[row]]
            if not finite[row]:
                text = f"{path} = {value} has a NaN or infinite value; predictions must be finite"
            else:
                text = (
                    f"{path} = {value} has x2 < x1 or y2 < y1; boxes are [x1, y1, x2, y2] "
                    "with the top-left corner first (swap the corners)"
                )
            self.problem(self._lines[r], text)
        self.problems.count += len(bad) - min(len(bad), shown)

    def finish(self, *, check: bool = True) -> Submission:
        """Run the file-wide checks and return the parsed table.

        With ``check`` (the default) any problem raises SubmissionError; without, the
        problems stay in :attr:`problems` for the caller to add its own and raise (the
        records with problems are left out of the table). Without a valid header it raises.
        """
        if not self._header_seen:
            self.problem(
                None,
                f"{self.source} holds no lines; a predictions file starts with a header line "
                "and has one line per instance",
            )
        n_rec = len(self._ids)
        nobj = np.array(self._nobj, dtype=np.int64)
        obj_off = offsets_from_lengths(nobj)
        boxes = self._array(self._boxes, 4, "boxes")
        nstates = np.array(self._nstates, dtype=np.int64)
        sb_off = offsets_from_lengths(nstates * nobj)
        step_boxes = self._array(self._step_boxes, 4, "step_boxes")
        has_pos = np.array(self._has_pos, dtype=bool)
        pos_rows = self._array(self._positions, 3, "positions")
        self._check_finite_ordered(boxes, obj_off, "boxes", True)
        self._check_finite_ordered(step_boxes, sb_off, "step_boxes", True, per_state=nobj)
        for arr in (boxes, step_boxes):  # reported above; keep later checks from repeating it
            arr[~np.isfinite(arr).all(axis=1)] = 0.0
        has_det = np.array(self._has_det, dtype=bool)
        det_rows = self._array(self._detections, 4, "detections")
        detections = np.zeros((int(obj_off[-1]), 4))
        if len(det_rows):
            detections[np.repeat(has_det, nobj)] = det_rows
            det_off = offsets_from_lengths(np.where(has_det, nobj, 0))
            self._check_finite_ordered(det_rows, det_off, "detections", True)
            det_rows[~np.isfinite(det_rows).all(axis=1)] = 0.0
            detections[np.repeat(has_det, nobj)] = det_rows
        positions = np.full((int(obj_off[-1]), 3), np.nan)
        if len(pos_rows):
            pos_obj = np.repeat(has_pos, nobj)
            positions[pos_obj] = pos_rows
            pos_off = offsets_from_lengths(np.where(has_pos, nobj, 0))
            self._check_finite_ordered(pos_rows, pos_off, "positions", False)
        if check or self.header is None:
            self.problems.raise_if_any()
        if self.header is None:  # pragma: no cover - a missing header is always a problem
            msg = f"{self.source}: the file has no valid header; {_FIX}"
            raise SubmissionError(msg)
        steps = np.array(self._steps, dtype=np.int64).reshape(-1, 3)

        def points(items: list[Any]) -> NDArray[np.float64]:
            out = np.full((n_rec, 2), np.nan)
            for i, p in enumerate(items):
                if p is not None:
                    out[i] = p
            return out

        return Submission(
            header=self.header,
            source=self.source,
            ids=tuple(self._ids),
            lines=np.array(self._lines, dtype=np.int64),
            obj_offsets=obj_off,
            boxes=boxes,
            has_step_boxes=np.array(self._has_sb, dtype=bool),
            n_step_states=nstates,
            stepbox_offsets=sb_off,
            step_boxes=step_boxes,
            has_program=np.array(self._has_prog, dtype=bool),
            program_offsets=offsets_from_lengths(np.array(self._prog_len, dtype=np.int64)),
            actions=steps[:, 0].astype(np.int8),
            subjects=steps[:, 1].copy(),
            references=steps[:, 2].copy(),
            pick=points(self._pick),
            place=points(self._place),
            has_positions=has_pos,
            positions=positions,
            line_label=self.label,
            has_detections=has_det if has_det.any() else None,
            detections=detections if has_det.any() else None,
            abstain=np.array(self._abstain, dtype=np.int8),
        )


def parse_submission(
    header: object,
    records: Iterable[object],
    *,
    source: str,
    first_line: int = 2,
    deep_type_check: bool = True,
) -> Submission:
    """Check and parse a header object and prediction objects (numbered from ``first_line``)."""
    parser = SubmissionParser(source)
    parser.parse_header(1, header)
    for k, obj in enumerate(records):
        parser.parse_record(first_line + k, obj, deep=deep_type_check)
    return parser.finish()


def parse_predictions(
    header: SubmissionHeader, predictions: Iterable[Prediction], *, source: str = "<memory>"
) -> Submission:
    """Check and parse in-memory predictions exactly as a file would be."""
    records = [p.to_record() for p in predictions]
    return parse_submission({"header": header.to_dict()}, iter(records), source=source,
                            first_line=2, deep_type_check=True)
