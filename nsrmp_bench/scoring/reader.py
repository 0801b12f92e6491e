"""Reading a predictions file (JSON Lines, gzip-compressed JSON Lines or Parquet) into a
checked :class:`Submission`.

A valid file is read in bulk (:mod:`nsrmp_bench.scoring.bulk`); a file the bulk reader
finds anything unusual in is read line by line by
:class:`~nsrmp_bench.scoring.validate.SubmissionParser`, which names every problem.

Every read is bounded by the part the file is for
(:class:`~nsrmp_bench.scoring.read_limits.ReadLimits`: given by the caller that holds the
gold, else from the committed manifest of the split the header names): JSON Lines are
read a chunk at a time and refused the moment they pass a bound; a Parquet file's row
count, leaf values and uncompressed bytes are checked in its footer before any page is read.
"""

from __future__ import annotations

import gc
import io
import json
from pathlib import Path
from typing import Any

from nsrmp_bench.errors import MissingExtra, SubmissionError
from nsrmp_bench.scoring.bulk import read_jsonl_bulk, read_parquet_bulk
from nsrmp_bench.scoring.file_formats import (
    PredictionsFormat,
    first_line,
    predictions_format,
    read_jsonl_bounded,
)
from nsrmp_bench.scoring.read_limits import HEADER_BYTES, ReadLimits
from nsrmp_bench.scoring.submission import PARQUET_COLUMNS, PARQUET_HEADER_KEY, Submission
from nsrmp_bench.scoring.validate import Problems, SubmissionParser

__all__ = ["claimed_split", "limits_for", "read_header", "read_submission",
           "read_submission_pending"]


def read_submission(path: str | Path, *, limits: ReadLimits | None = None) -> Submission:
    """Read and check a predictions file; ``.parquet`` by suffix, ``.gz`` gzip-compressed
    JSON Lines, anything else JSON Lines (:mod:`~nsrmp_bench.scoring.file_formats`).

    Raises :class:`SubmissionError` listing every problem (with its line) if the file is
    not a valid predictions file, or at once when it passes ``limits`` (default:
    :func:`limits_for`).
    """
    sub, problems = read_submission_pending(path, limits=limits)
    problems.raise_if_any()
    return sub


def limits_for(path: str | Path) -> ReadLimits:
    """The bounds of reading ``path`` when the caller holds no gold: the committed manifest
    of the official split its header names, else the fixed bounds for an unknown part."""
    split = claimed_split(path)
    known = ReadLimits.committed(split) if split is not None else None
    return known if known is not None else ReadLimits.unknown_part()


def claimed_split(path: str | Path) -> str | None:
    """The split a predictions file's header names, its first line read alone; None when
    the file has no readable header naming one (reading it whole then names the problem)."""
    try:
        split = read_header(path).get("split")
    except SubmissionError:
        return None
    return split if isinstance(split, str) else None


def read_submission_pending(path: str | Path, *, limits: ReadLimits | None = None
                            ) -> tuple[Submission, Problems]:
    """Read a predictions file, returning the problems found instead of raising them.

    The table leaves out the lines with problems. A caller that checks more (against the
    split's data) adds its problems to the same list and raises once, so a user sees every
    problem of the file in one message. A file without a valid header, or one that passes
    ``limits`` (default: :func:`limits_for`), raises at once.
    """
    p = Path(path)
    if not p.is_file():
        what = "is a directory" if p.is_dir() else "does not exist"
        msg = (f"predictions file {str(p)!r} {what}; pass the path of a .jsonl, .jsonl.gz or "
               ".parquet file")
        raise SubmissionError(msg)
    bounds = limits if limits is not None else limits_for(p)
    # Parsed JSON holds millions of small lists and no reference cycles: pausing the cyclic
    # garbage collector while they are built saves it rescanning them over and over.
    enabled = gc.isenabled()
    gc.disable()
    try:
        fmt = predictions_format(p)
        if fmt is PredictionsFormat.PARQUET:
            parsed = _read_parquet(p, bounds)
        else:
            data = read_jsonl_bounded(p, bounds)
            bulk = read_jsonl_bulk(str(p), data)
            parsed = bulk if bulk is not None else _read_jsonl(p, data)
        if isinstance(parsed, Submission):
            return parsed, Problems(str(p))
        return parsed.finish(check=False), parsed.problems
    finally:
        if enabled:
            gc.enable()


def read_header(path: str | Path) -> dict[str, object]:
    """The header object of a predictions file, read alone (its first line, or a Parquet
    file's schema metadata); not checked beyond being an object. For the header of a file
    that must be valid, read it with :func:`read_submission`."""
    p = Path(path)
    if not p.is_file():
        msg = (f"predictions file {str(p)!r} does not exist; pass a .jsonl, .jsonl.gz or "
               ".parquet file")
        raise SubmissionError(msg)
    if predictions_format(p) is PredictionsFormat.PARQUET:
        from nsrmp_bench._optional import require

        try:
            meta = require("pyarrow.parquet").read_schema(p).metadata or {}
        except MissingExtra:
            raise
        except Exception as exc:  # pyarrow raises several unrelated types for a bad file
            msg = (f"{p}: not a readable Parquet file ({exc}); write it with pyarrow or use "
                   ".jsonl")
            raise SubmissionError(msg) from exc
        raw = meta.get(PARQUET_HEADER_KEY.encode(), b"null")
        if len(raw) > HEADER_BYTES:
            msg = (f"{p}: its {PARQUET_HEADER_KEY!r} metadata is longer than {HEADER_BYTES} "
                   "bytes; expected the header object alone: store only the header there")
            raise SubmissionError(msg)
        line = b'{"header": ' + raw + b"}"
    else:
        line = first_line(p)
    try:
        obj: object = json.loads(line)
    except (json.JSONDecodeError, UnicodeDecodeError):
        obj = None
    header = obj.get("header") if isinstance(obj, dict) else None
    if not isinstance(header, dict):
        msg = (f"predictions file {str(p)!r} has no header object on its first line; check it "
               "with `nsrmp-bench check-submission`")
        raise SubmissionError(msg)
    return header


def _read_jsonl(path: Path, data: bytes) -> SubmissionParser:
    """Every line through the line-by-line parser, which names each problem."""
    parser = SubmissionParser(str(path))
    header_done = False
    for lineno, raw in enumerate(io.BytesIO(data), 1):
        if not raw.strip():
            continue
        try:
            text = raw.decode("utf-8").rstrip("\r\n")
        except UnicodeDecodeError as exc:
            parser.problem(
                lineno,
                f"is not UTF-8 text (byte {exc.start + 1}); write the file as UTF-8 JSON",
            )
            header_done = True
            continue
        try:
            obj: object = json.loads(text)
        except json.JSONDecodeError as exc:
            parser.problem(
                lineno,
                f"is not valid JSON ({exc.msg} at column {exc.colno}); each line must be "
                "one complete JSON object",
            )
            header_done = True
            continue
        except RecursionError:
            parser.problem(lineno, "nests too deeply to be a prediction; check the line")
            header_done = True
            continue
        if not header_done:
            parser.parse_header(lineno, obj)
            header_done = True
            continue
        # Booleans are numbers to numpy: scan lines that could hold one in Python.
        parser.parse_record(lineno, obj, deep=b"true" in raw or b"false" in raw)
    return parser


def _check_parquet_footer(path: Path, pq: Any, limits: ReadLimits) -> None:
    """Refuse a Parquet file whose footer says it holds more than ``limits`` allow, before
    any page is read (a few kilobytes of pages can expand to gigabytes)."""
    meta = pq.ParquetFile(path).metadata
    where = f"{path}: a Parquet file for {limits.describe()}"
    if meta.num_rows > limits.instances:
        msg = (f"{where} holds at most {limits.instances} rows, this one {meta.num_rows}; "
               "write one row per instance")
        raise SubmissionError(msg)
    values = 0
    size = 0
    for g in range(meta.num_row_groups):
        group = meta.row_group(g)
        size += group.total_byte_size
        for c in range(group.num_columns):
            values += group.column(c).num_values
    if values > limits.numbers or size > limits.file_bytes:
        msg = (f"{where} holds at most {limits.numbers} values and {limits.file_bytes} "
               f"bytes, this one {values} values and {size} bytes uncompressed; reading "
               "stopped before its pages. Write boxes, program and points only")
        raise SubmissionError(msg)


def _read_parquet(path: Path, limits: ReadLimits | None = None) -> SubmissionParser | Submission:
    from nsrmp_bench._optional import require

    try:
        pq = require("pyarrow.parquet")
    except MissingExtra as exc:
        msg = f"{path}: reading Parquet predictions needs pyarrow ({exc}); or write JSON Lines"
        raise SubmissionError(msg) from exc
    try:
        _check_parquet_footer(path, pq, limits if limits is not None else limits_for(path))
    except SubmissionError:
        raise
    except Exception as exc:  # pyarrow raises several unrelated types for a bad file
        msg = f"{path}: not a readable Parquet file ({exc}); write it with pyarrow or use .jsonl"
        raise SubmissionError(msg) from exc
    try:
        table = pq.read_table(path)
    except Exception as exc:  # pyarrow raises several unrelated types for a bad file
        msg = f"{path}: not a readable Parquet file ({exc}); write it with pyarrow or use .jsonl"
        raise SubmissionError(msg) from exc
    parser = SubmissionParser(str(path), line_label="row")
    meta = table.schema.metadata or {}
    raw_header = meta.get(PARQUET_HEADER_KEY.encode())
    if raw_header is None:
        msg = (
            f"{path}: the Parquet schema metadata has no {PARQUET_HEADER_KEY!r} key; store the "
            "header object's JSON text there (see nsrmp_bench.scoring.submission.write_submission)"
        )
        raise SubmissionError(msg)
    try:
        header = json.loads(raw_header)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        msg = f"{path}: its {PARQUET_HEADER_KEY!r} metadata is not JSON ({exc}); store the header"
        raise SubmissionError(msg) from exc
    parser.parse_header(None, {"header": header})
    if parser.header is not None and not parser.problems.count:
        bulk = read_parquet_bulk(str(path), table, parser.header)
        if bulk is not None:
            return bulk
    unknown = [c for c in table.column_names if c not in PARQUET_COLUMNS]
    if unknown:
        msg = (
            f"{path}: unknown columns {unknown}; a predictions table has only "
            f"{list(PARQUET_COLUMNS)}"
        )
        raise SubmissionError(msg)
    for row, record in enumerate(table.to_pylist(), 1):
        rec = {k: v for k, v in record.items() if v is not None}
        program = rec.get("program")
        if isinstance(program, list):
            rec["program"] = [
                [s.get("action"), s.get("subject"), s.get("reference")]
                if isinstance(s, dict)
                else s
                for s in program
            ]
        parser.parse_record(row, rec, deep=False)
    return parser
