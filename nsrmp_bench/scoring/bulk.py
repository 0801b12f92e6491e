"""Reading a well-formed predictions file in bulk, without a Python object per number.

JSON Lines: msgspec decodes each line's structure in C (ids and programs typed, the number
fields kept as raw JSON text). The raw text of each number field, joined over the file, is
checked as nested arrays of numbers from its bracket positions with numpy (depth, arrays
per array against the line's ``boxes``, nothing but commas between arrays), and read in
one call: by pyarrow's CSV reader where installed, one row per innermost array (which
checks each array's count of numbers), else counted with numpy and read by numpy's text
reader. Both round correctly, as ``json`` does. Parquet: the typed columns are checked and
flattened with pyarrow.

This is a fast path only. It returns ``None`` as soon as anything is unusual (a problem,
a blank line, a detections field, a number outside what it can prove it reads exactly);
the caller then reads the file line by line with :class:`~nsrmp_bench.scoring.validate.
SubmissionParser`, which finds and names every problem. So a valid file gives the same
:class:`Submission`, bit for bit, on either path, and every error message comes from the
line-by-line parser.
"""

from __future__ import annotations

import io
import json
from collections.abc import Sequence
from typing import Any

import msgspec
import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.scoring.ragged import offsets_from_lengths
from nsrmp_bench.scoring.submission import PARQUET_COLUMNS, Submission, SubmissionHeader
from nsrmp_bench.scoring.validate import SubmissionParser
from nsrmp_bench.vocabulary import ACTIONS

__all__ = ["numbers_arrow", "numbers_numpy", "read_jsonl_bulk", "read_parquet_bulk"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

_NULL = msgspec.Raw(b"null")
_ACTION_CODE = {a: i for i, a in enumerate(ACTIONS)}
_MAX_EXACT = 2.0**53  # larger numbers: the line-by-line parser decides (ints are refused)

# the bytes of nested arrays of JSON numbers (whitespace removed): 1 a number's, 2 [, 3 ],
# 0 a comma, 4 any other
_SPACES = b" \t\r\n"
_KIND = bytes(2 if c == ord("[") else 3 if c == ord("]") else 0 if c == ord(",") else
              1 if c in b"0123456789.-+eE" else 4 for c in range(256))
_NUMBERS_ONLY = bytes(c if c in b"0123456789.-+eE" else ord("\n") for c in range(256))
_ROWS = bytes(ord("\n") if c in b"[]" else c for c in range(256))
_NEWLINE = ord("\n")


class _Line(msgspec.Struct, forbid_unknown_fields=True):
    """One prediction line as msgspec decodes it (numbers stay raw JSON text)."""

    id: str
    boxes: msgspec.Raw
    program: list[tuple[str, int, int]] | None = None
    step_boxes: msgspec.Raw = _NULL
    pick: msgspec.Raw = _NULL
    place: msgspec.Raw = _NULL
    positions: msgspec.Raw = _NULL
    detections: msgspec.Raw = _NULL


_DECODER = msgspec.json.Decoder(_Line)


class _Unusual(Exception):
    """Leave the fast path: the line-by-line parser reads the file."""


def _header(source: str, line: bytes, label: str) -> SubmissionHeader:
    """The header, if the line-by-line parser finds it valid."""
    parser = SubmissionParser(source, line_label=label)
    try:
        obj = json.loads(line.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise _Unusual from exc
    parser.parse_header(1 if label == "line" else None, obj)
    if parser.problems.count or parser.header is None:
        raise _Unusual
    return parser.header


def read_jsonl_bulk(source: str, data: bytes) -> Submission | None:
    """The parsed submission of a valid JSON Lines file, or None (read it line by line)."""
    try:
        return _read_jsonl(source, data)
    except _Unusual:
        return None


def _read_jsonl(source: str, data: bytes) -> Submission:
    end = data.find(b"\n")
    if end < 0 or not data[:end].strip():
        raise _Unusual
    header = _header(source, data[:end], "line")
    body = data[end + 1 :]
    n_lines = body.count(b"\n") + (1 if body and not body.endswith(b"\n") else 0)
    try:
        lines: list[_Line] = _DECODER.decode_lines(body)
    except (msgspec.DecodeError, RecursionError) as exc:
        raise _Unusual from exc
    if not lines or len(lines) != n_lines:  # blank lines, or several objects on one line
        raise _Unusual
    ids = tuple(line.id for line in lines)
    if any(line.detections != _NULL for line in lines):
        raise _Unusual
    boxes, (nobj,) = _arrays([line.boxes for line in lines], 2, 4)
    if not nobj.all():
        raise _Unusual

    has_sb = np.array([line.step_boxes != _NULL for line in lines], dtype=bool)
    nstates = np.zeros(len(lines), dtype=np.int64)
    step_boxes = np.zeros((0, 4))
    if has_sb.any():
        step_boxes, (states, per_state) = _arrays(
            [line.step_boxes for line in lines if line.step_boxes != _NULL], 3, 4
        )
        if (per_state != np.repeat(nobj[has_sb], states)).any():
            raise _Unusual
        nstates[has_sb] = states

    has_pos = np.array([line.positions != _NULL for line in lines], dtype=bool)
    positions = np.full((len(boxes), 3), np.nan)
    if has_pos.any():
        rows, (count,) = _arrays(
            [line.positions for line in lines if line.positions != _NULL], 2, 3
        )
        if (count != nobj[has_pos]).any():
            raise _Unusual
        positions[np.repeat(has_pos, nobj)] = rows

    pick = _points([line.pick for line in lines])
    place = _points([line.place for line in lines])
    has_prog = np.array([line.program is not None for line in lines], dtype=bool)
    prog_len = np.array([len(line.program or ()) for line in lines], dtype=np.int64)
    steps = [step for line in lines if line.program for step in line.program]
    return _submission(
        header, source, ids, np.arange(2, len(lines) + 2, dtype=np.int64), nobj, boxes,
        has_sb, nstates, step_boxes, has_prog, prog_len,
        [a for a, _, _ in steps], [s for _, s, _ in steps], [r for _, _, r in steps],
        pick, place, has_pos, positions, "line",
    )


def _submission(
    header: SubmissionHeader, source: str, ids: tuple[str, ...], lines: I64, nobj: I64,
    boxes: F64, has_sb: NDArray[np.bool_], nstates: I64, step_boxes: F64,
    has_prog: NDArray[np.bool_], prog_len: I64, actions: Sequence[str],
    subjects: Sequence[int] | I64, references: Sequence[int] | I64, pick: F64, place: F64,
    has_pos: NDArray[np.bool_], positions: F64, label: str,
) -> Submission:
    """The checked table, as :meth:`SubmissionParser.finish` builds it."""
    if len(set(ids)) != len(ids) or not all(ids):
        raise _Unusual
    for arr in (boxes, step_boxes):
        if (arr[:, 2] < arr[:, 0]).any() or (arr[:, 3] < arr[:, 1]).any():
            raise _Unusual
    codes = np.array([_ACTION_CODE.get(a, -1) for a in actions], dtype=np.int64)
    subj = np.asarray(subjects, dtype=np.int64)
    ref = np.asarray(references, dtype=np.int64)
    n_of_step = np.repeat(nobj, prog_len)
    if (
        (codes < 0).any()
        or (subj < 0).any() or (subj >= n_of_step).any()
        or (ref < 0).any() or (ref >= n_of_step).any()
    ):
        raise _Unusual
    obj_off = offsets_from_lengths(nobj)
    return Submission(
        header=header,
        source=source,
        ids=ids,
        lines=lines,
        obj_offsets=obj_off,
        boxes=boxes,
        has_step_boxes=has_sb,
        n_step_states=nstates,
        stepbox_offsets=offsets_from_lengths(nstates * nobj),
        step_boxes=step_boxes,
        has_program=has_prog,
        program_offsets=offsets_from_lengths(prog_len),
        actions=codes.astype(np.int8),
        subjects=subj,
        references=ref,
        pick=pick,
        place=place,
        has_positions=has_pos,
        positions=positions,
        line_label=label,
    )


def _points(raws: list[msgspec.Raw]) -> F64:
    """``[x, y]`` per line, NaN where absent."""
    out = np.full((len(raws), 2), np.nan)
    present = np.array([r != _NULL for r in raws], dtype=bool)
    if present.any():
        rows, _ = _arrays([r for r in raws if r != _NULL], 1, 2)
        out[present] = rows
    return out


def _arrays(raws: Sequence[msgspec.Raw], depth: int, width: int) -> tuple[F64, list[I64]]:
    """Numbers nested ``depth`` arrays deep, ``width`` per innermost array, from raw JSON.

    Returns the ``(M, width)`` rows and, for each level above the innermost, the number of
    arrays each array holds (for depth 2: boxes per line; for depth 3: states per line and
    boxes per state). Raises :class:`_Unusual` for anything but that shape of numbers.
    msgspec has checked that each raw value is valid JSON, so only the shape is left.
    """
    text = b"".join(raws)
    if any(space in text for space in _SPACES):
        text = text.translate(None, _SPACES)
    kind = np.frombuffer(text.translate(_KIND), dtype=np.uint8)  # 1 digit, 2 [, 3 ], 0 ,
    where = np.flatnonzero(kind >= 2)  # the brackets, in order (and any other byte)
    kinds = kind[where]
    if kinds.max(initial=0) > 3:  # strings, objects, true, false, null
        raise _Unusual
    opening = kinds == 2
    level = np.cumsum(np.where(opening, 1, -1).astype(np.int32))  # depth after each bracket
    if level.max(initial=0) > depth:
        raise _Unusual
    starts = [where[opening & (level == d)] for d in range(1, depth + 1)]
    if len(starts[0]) != len(raws):
        raise _Unusual
    # an innermost array's closing bracket is the next bracket after its opening one;
    # between any other two brackets there is nothing or one comma (a number is an error)
    innermost = opening & (level == depth)
    inner = np.flatnonzero(innermost)
    gap = np.diff(where) - 1
    outside = ~innermost[:-1]
    if (gap[outside] > 1).any():
        raise _Unusual
    between = where[:-1][outside & (gap == 1)] + 1  # commas between arrays, or a number
    if (kind[between] != 0).any():
        raise _Unusual
    counts = [_children(starts[d], starts[d + 1]) for d in range(depth - 1)]
    values = _rows(text, kind, where, inner, between, width)
    if (
        not np.isfinite(values).all()
        or (np.abs(values) > _MAX_EXACT).any()
        or ((values == 0) & np.signbit(values)).any()  # -0: json reads the int 0 as +0.0
    ):
        raise _Unusual
    return values, counts


def _rows(text: bytes, kind: NDArray[np.uint8], where: I64, inner: I64, between: I64,
          width: int) -> F64:
    """The numbers of each innermost array (``width`` each, else :class:`_Unusual`)."""
    if not len(inner):
        return np.zeros((0, width))
    try:  # one CSV row per innermost array: pyarrow checks each row's count
        lines = np.frombuffer(text, dtype=np.uint8).copy()
        lines[between] = _NEWLINE
        values = numbers_arrow(lines.tobytes().translate(_ROWS), width)
    except ImportError:  # count each array's numbers here, then read them with numpy
        digit = kind == 1
        first = np.flatnonzero(digit[1:] > digit[:-1]) + 1  # where each number starts
        inside = (np.searchsorted(first, where[inner + 1])
                  - np.searchsorted(first, where[inner]))
        if (inside != width).any():
            raise _Unusual from None
        flat = numbers_numpy(text.translate(_NUMBERS_ONLY))
        if len(flat) != width * len(inner):
            raise _Unusual from None
        values = flat.reshape(-1, width)
    if len(values) != len(inner):  # an empty innermost array
        raise _Unusual
    return values


def _children(parents: I64, children: I64) -> I64:
    """How many of the (sorted) ``children`` positions fall under each parent position."""
    at = np.searchsorted(children, parents)
    out: I64 = np.diff(np.append(at, len(children))).astype(np.int64)
    return out


def numbers_arrow(text: bytes, width: int = 1) -> F64:
    """Lines of ``width`` comma-separated numbers, read by pyarrow's CSV reader, as a
    ``(lines, width)`` array (empty lines skipped; ImportError without pyarrow)."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    names = [f"c{k}" for k in range(width)]
    try:
        table = pcsv.read_csv(
            io.BytesIO(text),
            read_options=pcsv.ReadOptions(column_names=names, block_size=1 << 24,
                                          use_threads=True),
            parse_options=pcsv.ParseOptions(quote_char=False),
            convert_options=pcsv.ConvertOptions(
                column_types=dict.fromkeys(names, pa.float64()), null_values=[],
                strings_can_be_null=False,
            ),
        )
    except (pa.ArrowException, ValueError) as exc:  # a line with another count of numbers
        raise _Unusual from exc
    if any(table.column(k).null_count for k in range(width)):
        raise _Unusual
    out = np.empty((table.num_rows, width))
    for k in range(width):
        out[:, k] = table.column(k).to_numpy()
    return out


def numbers_numpy(text: bytes) -> F64:
    """Newline-terminated numbers read by numpy's text reader (the core install's path)."""
    try:
        values: F64 = np.fromstring(text, dtype=np.float64, sep="\n")
    except ValueError as exc:
        raise _Unusual from exc
    return values


def read_parquet_bulk(source: str, table: Any, header: SubmissionHeader) -> Submission | None:
    """The parsed submission of a valid predictions table, or None (read it row by row)."""
    try:
        return _read_parquet(source, table, header)
    except _Unusual:
        return None


def _read_parquet(source: str, table: Any, header: SubmissionHeader) -> Submission:
    import pyarrow as pa
    import pyarrow.compute as pc

    n = table.num_rows
    if n == 0 or any(c not in PARQUET_COLUMNS for c in table.column_names):
        raise _Unusual
    cols = {c: table.column(c).combine_chunks() for c in table.column_names}
    if "detections" in cols and cols["detections"].null_count != n:
        raise _Unusual
    ids_col = cols.get("id")
    if ids_col is None or not pa.types.is_string(ids_col.type) or ids_col.null_count:
        raise _Unusual
    ids = tuple(ids_col.to_pylist())

    def nested(name: str, depth: int, width: int) -> tuple[NDArray[np.bool_], F64, list[I64]]:
        """Present rows, values and per-level counts of a list column ``depth`` deep."""
        col = cols.get(name)
        if col is None:
            return np.zeros(n, dtype=bool), np.zeros((0, width)), [np.zeros(0, np.int64)] * (
                depth - 1)
        present = np.asarray(col.is_valid().to_numpy(zero_copy_only=False), dtype=bool)
        arr = col.drop_null() if col.null_count else col
        counts: list[I64] = []
        for _ in range(depth):
            if not pa.types.is_list(arr.type) and not pa.types.is_large_list(arr.type):
                raise _Unusual
            lengths = pc.list_value_length(arr)
            if lengths.null_count:
                raise _Unusual
            counts.append(np.asarray(lengths.to_numpy(), dtype=np.int64))
            arr = arr.flatten()
        if not pa.types.is_floating(arr.type) and not pa.types.is_integer(arr.type):
            raise _Unusual
        if arr.null_count or (counts[-1] != width).any():
            raise _Unusual
        values = np.asarray(arr.to_numpy(), dtype=np.float64)
        if not np.isfinite(values).all() or (pa.types.is_integer(arr.type) and (
                np.abs(values) > _MAX_EXACT).any()):
            raise _Unusual
        return present, values.reshape(-1, width), counts[:-1]

    has_box, boxes, (nobj,) = nested("boxes", 2, 4)
    if not has_box.all() or not nobj.all():
        raise _Unusual
    has_sb, step_boxes, (states, per_state) = nested("step_boxes", 3, 4)
    if (per_state != np.repeat(nobj[has_sb], states)).any():
        raise _Unusual
    nstates = np.zeros(n, dtype=np.int64)
    nstates[has_sb] = states
    has_pos, pos_rows, (count,) = nested("positions", 2, 3)
    if (count != nobj[has_pos]).any():
        raise _Unusual
    positions = np.full((len(boxes), 3), np.nan)
    positions[np.repeat(has_pos, nobj)] = pos_rows
    points = []
    for name in ("pick", "place"):
        present, rows, _ = nested(name, 1, 2)
        out = np.full((n, 2), np.nan)
        out[present] = rows
        points.append(out)

    prog = cols.get("program")
    has_prog = np.zeros(n, dtype=bool)
    prog_len = np.zeros(n, dtype=np.int64)
    actions: list[str] = []
    subjects: I64 = np.zeros(0, np.int64)
    references: I64 = np.zeros(0, np.int64)
    if prog is not None:
        if not pa.types.is_list(prog.type) or not pa.types.is_struct(prog.type.value_type):
            raise _Unusual
        has_prog = np.asarray(prog.is_valid().to_numpy(zero_copy_only=False), dtype=bool)
        present = prog.drop_null() if prog.null_count else prog
        prog_len[has_prog] = np.asarray(pc.list_value_length(present).to_numpy(), np.int64)
        steps = present.flatten()
        if steps.null_count or {f.name for f in steps.type} != {
                "action", "subject", "reference"}:
            raise _Unusual
        act, sub, ref = (steps.field(k) for k in ("action", "subject", "reference"))
        if (act.null_count or sub.null_count or ref.null_count
                or not pa.types.is_string(act.type) or not pa.types.is_integer(sub.type)
                or not pa.types.is_integer(ref.type)):
            raise _Unusual
        actions = act.to_pylist()
        subjects = np.asarray(sub.to_numpy(), dtype=np.int64)
        references = np.asarray(ref.to_numpy(), dtype=np.int64)
    return _submission(
        header, source, ids, np.arange(1, n + 1, dtype=np.int64), nobj, boxes, has_sb,
        nstates, step_boxes, has_prog, prog_len, actions, subjects, references, points[0],
        points[1], has_pos, positions, "row",
    )
