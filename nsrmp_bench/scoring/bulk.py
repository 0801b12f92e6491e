"""Reading a well-formed predictions file in bulk, without a Python object per number.

JSON Lines: msgspec decodes each line's structure in C (ids and programs typed, the number
fields kept as raw JSON text). The raw text of each number field, joined over the file, is
checked as nested arrays of numbers from its shape, the few bytes left with the numbers
deleted (depth, arrays per array against the line's ``boxes``), and its numbers are read in
one call: by pyarrow's CSV reader where installed, else by numpy's text reader. Both round
correctly, as ``json`` does. Parquet: the typed columns are checked and flattened with
pyarrow.

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
from itertools import chain, repeat
from operator import attrgetter, is_not
from typing import TYPE_CHECKING

import msgspec
import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.scoring.ragged import offsets_from_lengths
from nsrmp_bench.scoring.submission import (
    ABSTAIN_CODES,
    PARQUET_COLUMNS,
    Submission,
    SubmissionHeader,
)
from nsrmp_bench.scoring.validate import SubmissionParser
from nsrmp_bench.vocabulary import ACTIONS

if TYPE_CHECKING:
    import pyarrow

__all__ = ["numbers_arrow", "numbers_numpy", "read_jsonl_bulk", "read_parquet_bulk"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

_NULL = msgspec.Raw(b"null")
_ACTION_CODE = {a: i for i, a in enumerate(ACTIONS)}
_MAX_EXACT = 2.0**53  # larger numbers: the line-by-line parser decides (ints are refused)

_NUMBER_BYTES = b"0123456789.-+eE"  # the bytes of JSON numbers
_SPACES = b" \t\r\n"  # JSON's whitespace
_LEAF = b"b"  # an innermost array, in the shape left when numbers are deleted
_NUMBERS_ONLY = bytes(c if c in _NUMBER_BYTES else ord("\n") for c in range(256))


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
    abstain: str | None = None


_DECODER = msgspec.json.Decoder(_Line)
# each line's field, for map(): faster than a comprehension over 100,000 lines
_ID, _BOXES, _PROGRAM, _STEP_BOXES = (attrgetter(f) for f in ("id", "boxes", "program",
                                                              "step_boxes"))
_PICK, _PLACE, _POSITIONS, _DETECTIONS = (attrgetter(f) for f in ("pick", "place",
                                                                  "positions", "detections"))
_ABSTAIN = attrgetter("abstain")
_ABSTAIN_CODE: dict[str | None, int] = {None: 0}
_ABSTAIN_CODE.update(ABSTAIN_CODES)


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
    body = memoryview(data)[end + 1 :]  # no copy of the file
    n_lines = data.count(b"\n", end + 1) + (0 if data.endswith(b"\n") else 1)
    try:
        lines: list[_Line] = _DECODER.decode_lines(body)
    except (msgspec.DecodeError, RecursionError) as exc:
        raise _Unusual from exc
    if not lines or len(lines) != n_lines:  # blank lines, or several objects on one line
        raise _Unusual
    ids = tuple(map(_ID, lines))
    if any(map(_NULL.__ne__, map(_DETECTIONS, lines))):
        raise _Unusual
    boxes, (nobj,) = _arrays(list(map(_BOXES, lines)), 2, 4)
    if not nobj.all():
        raise _Unusual

    has_sb, sb_raws = _present(list(map(_STEP_BOXES, lines)))
    nstates = np.zeros(len(lines), dtype=np.int64)
    step_boxes = np.zeros((0, 4))
    if sb_raws:
        step_boxes, (states, per_state) = _arrays(sb_raws, 3, 4)
        if (per_state != np.repeat(nobj[has_sb], states)).any():
            raise _Unusual
        nstates[has_sb] = states

    has_pos, pos_raws = _present(list(map(_POSITIONS, lines)))
    positions = np.full((len(boxes), 3), np.nan)
    if pos_raws:
        rows, (count,) = _arrays(pos_raws, 2, 3)
        if (count != nobj[has_pos]).any():
            raise _Unusual
        positions[np.repeat(has_pos, nobj)] = rows

    pick = _points(list(map(_PICK, lines)))
    place = _points(list(map(_PLACE, lines)))
    programs = list(map(_PROGRAM, lines))
    has_prog = np.fromiter(map(is_not, programs, repeat(None)), dtype=bool, count=len(lines))
    prog_len = np.fromiter((len(p) if p else 0 for p in programs), dtype=np.int64,
                           count=len(lines))
    steps = list(chain.from_iterable(filter(None, programs)))
    actions, subjects, references = zip(*steps, strict=True) if steps else ((), (), ())
    abstain = _abstain_codes(list(map(_ABSTAIN, lines)))
    return _submission(
        header, source, ids, np.arange(2, len(lines) + 2, dtype=np.int64), nobj, boxes,
        has_sb, nstates, step_boxes, has_prog, prog_len, actions, subjects, references,
        pick, place, has_pos, positions, "line", abstain,
    )


def _abstain_codes(values: list[str | None]) -> NDArray[np.int8]:
    """Each line's abstain code (0 where none); an unknown value is :class:`_Unusual`."""
    if values.count(None) == len(values):
        return np.zeros(len(values), dtype=np.int8)
    codes = np.fromiter(map(_ABSTAIN_CODE.get, values, repeat(-1)), dtype=np.int64,
                        count=len(values))
    if (codes < 0).any():
        raise _Unusual
    return codes.astype(np.int8)


def _present(raws: list[msgspec.Raw]) -> tuple[NDArray[np.bool_], list[msgspec.Raw]]:
    """Which lines give a field (not ``null``), and the values they give."""
    present = np.fromiter(map(_NULL.__ne__, raws), dtype=bool, count=len(raws))
    if present.all():
        return present, raws
    return present, [r for r, p in zip(raws, present.tolist(), strict=True) if p]


def _submission(
    header: SubmissionHeader, source: str, ids: tuple[str, ...], lines: I64, nobj: I64,
    boxes: F64, has_sb: NDArray[np.bool_], nstates: I64, step_boxes: F64,
    has_prog: NDArray[np.bool_], prog_len: I64, actions: Sequence[str],
    subjects: Sequence[int] | I64, references: Sequence[int] | I64, pick: F64, place: F64,
    has_pos: NDArray[np.bool_], positions: F64, label: str, abstain: NDArray[np.int8],
) -> Submission:
    """The checked table, as :meth:`SubmissionParser.finish` builds it."""
    if len(set(ids)) != len(ids) or not all(ids):
        raise _Unusual
    abstained = abstain > 0
    if abstained.any() and (
        (prog_len[abstained] > 0).any() or has_sb[abstained].any()
        or not np.isnan(pick[abstained]).all() or not np.isnan(place[abstained]).all()
    ):
        raise _Unusual  # an abstention that acts: the line-by-line parser names the line
    for arr in (boxes, step_boxes):
        if (arr[:, 2] < arr[:, 0]).any() or (arr[:, 3] < arr[:, 1]).any():
            raise _Unusual
    codes = np.fromiter(map(_ACTION_CODE.get, actions, repeat(-1)), dtype=np.int64,
                        count=len(actions))
    try:
        subj = np.asarray(subjects, dtype=np.int64)
        ref = np.asarray(references, dtype=np.int64)
    except (OverflowError, TypeError, ValueError):  # 2**70: the line parser names it
        raise _Unusual from None
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
        abstain=abstain,
    )


def _points(raws: list[msgspec.Raw]) -> F64:
    """``[x, y]`` per line, NaN where absent."""
    out = np.full((len(raws), 2), np.nan)
    present, given = _present(raws)
    if given:
        rows, _ = _arrays(given, 1, 2)
        out[present] = rows
    return out


def _arrays(raws: Sequence[msgspec.Raw], depth: int, width: int) -> tuple[F64, list[I64]]:
    """Numbers nested ``depth`` arrays deep, ``width`` per innermost array, from raw JSON.

    Returns the ``(M, width)`` rows and, for each level above the innermost, the number of
    arrays each array holds (for depth 2: boxes per line; for depth 3: states per line and
    boxes per state). Raises :class:`_Unusual` for anything but that shape of numbers.

    msgspec has checked that each raw value is valid JSON, so only the shape is left. With
    the numbers and spaces deleted, an innermost array of ``width`` numbers reads
    ``[,,,]`` (width 4) and becomes one leaf byte; the few bytes left are checked with
    numpy (only brackets, commas and leaves; leaves exactly ``depth - 1`` arrays deep, no
    array deeper). The numbers, one a line, are read in one call and counted: a number
    outside an innermost array of ``width`` is one too many.
    """
    text = b"".join(raws)
    leaf = b"[" + b"," * (width - 1) + b"]"
    shape = text.translate(None, _NUMBER_BYTES + _SPACES).replace(leaf, _LEAF)
    if shape.translate(None, b"[]," + _LEAF):  # strings, objects, true, false, null
        raise _Unusual
    s = np.frombuffer(shape, dtype=np.uint8)
    opening = s == ord("[")
    level = np.cumsum(opening.astype(np.int32) - (s == ord("]")))  # depth after each byte
    if level.max(initial=0) >= depth:  # an innermost array of another width, or deeper
        raise _Unusual
    leaves = np.flatnonzero(s == _LEAF[0])
    if (level[leaves] != depth - 1).any():  # a leaf at another depth
        raise _Unusual
    starts = [np.flatnonzero(opening & (level == d)) for d in range(1, depth)]
    starts.append(leaves)
    if len(starts[0]) != len(raws):  # a raw value that is not an array
        raise _Unusual
    counts = [_children(starts[d], starts[d + 1]) for d in range(depth - 1)]
    values = _numbers(text, len(leaves), width)
    if values.size and not -_MAX_EXACT <= values.min() <= values.max() <= _MAX_EXACT:
        raise _Unusual  # NaN, infinity, beyond 2**53
    negative = np.signbit(values)
    if negative.any() and (values[negative] == 0).any():
        raise _Unusual  # -0: json reads the int 0 as +0.0
    return values, counts


def _numbers(text: bytes, rows: int, width: int) -> F64:
    """The ``rows`` innermost arrays' numbers, ``(rows, width)``, from the joined raw text
    of arrays whose shape is checked; any other count of numbers (one outside an innermost
    array) is :class:`_Unusual`. The numbers are read one a line: by pyarrow's CSV reader
    where installed, else by numpy's text reader."""
    lines = text.translate(_NUMBERS_ONLY)
    if not rows:
        if lines.strip():
            raise _Unusual
        return np.zeros((0, width))
    try:
        flat = numbers_arrow(lines).reshape(-1)
    except ImportError:
        flat = numbers_numpy(lines)
    if len(flat) != rows * width:
        raise _Unusual
    return flat.reshape(rows, width)


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
    if width == 1:
        flat = np.asarray(table.column(0).to_numpy(), dtype=np.float64)
        return (flat if flat.flags.writeable else flat.copy()).reshape(-1, 1)
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


def read_parquet_bulk(source: str, table: pyarrow.Table,
                      header: SubmissionHeader) -> Submission | None:
    """The parsed submission of a valid predictions table, or None (read it row by row)."""
    try:
        return _read_parquet(source, table, header)
    except _Unusual:
        return None


def _read_parquet(source: str, table: pyarrow.Table, header: SubmissionHeader) -> Submission:
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
    abstain = np.zeros(n, dtype=np.int8)
    abst = cols.get("abstain")
    if abst is not None and abst.null_count != n:
        if not pa.types.is_string(abst.type):
            raise _Unusual
        abstain = _abstain_codes(abst.to_pylist())
    return _submission(
        header, source, ids, np.arange(1, n + 1, dtype=np.int64), nobj, boxes, has_sb,
        nstates, step_boxes, has_prog, prog_len, actions, subjects, references, points[0],
        points[1], has_pos, positions, "row", abstain,
    )
