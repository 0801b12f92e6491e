"""The predictions file: its header, one prediction per instance, and the parsed table.

A predictions file is JSON Lines (gzip-compressed as ``.jsonl.gz``, or Parquet with the
same columns). Its first line is the
header, every further line one instance::

    {"header": {"format": "nsrmp-bench-predictions", "format_version": "1.1.0",
                "split": "smoke-v2", "scorer": "scorer-v2", "model": "my-model"}}
    {"id": "smoke-v2/000000", "boxes": [[x1, y1, x2, y2], ...],
     "program": [["top", 2, 0]], "pick": [u, v], "place": [u, v],
     "step_boxes": [[[x1, y1, x2, y2], ...]], "positions": [[x, y, z], ...]}

``boxes`` (required) are the predicted final amodal boxes, pixel xyxy, one per object in
the episode's object order. Optional: ``step_boxes`` (the boxes after each step, one list
per step), ``program`` (the predicted grounded program: ``[action, subject, reference]``
per step, object indices in episode order), ``pick`` / ``place`` (pixel locations, for the
identification and placement accuracies) and ``positions`` (predicted final object centres
in metres, world frame) and (format 1.1.0) ``abstain`` (``"no action"`` or ``"not
feasible"``: the model declines to act; see :data:`ABSTAIN_VALUES`). ``null`` means
absent. In Parquet the header is the JSON text of the schema metadata key
``nsrmp_bench.header``. ``submission.schema.json`` documents one line;
:mod:`nsrmp_bench.scoring.validate` enforces it with messages that name the line.
"""

from __future__ import annotations

import io
import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from types import ModuleType
from typing import Any, TextIO

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scoring.file_formats import PredictionsFormat, write_jsonl_bytes, written_format
from nsrmp_bench.scoring.version import (
    ABSTAIN_FORMAT_VERSION,
    ABSTAIN_SCORER_ID,
    BASE_FORMAT_VERSION,
    SUBMISSION_FORMAT,
    WRITTEN_SCORER_ID,
)
from nsrmp_bench.storage.atomic import atomic_open, atomic_path

__all__ = [
    "ABSTAIN_CODES",
    "ABSTAIN_VALUES",
    "PARQUET_COLUMNS",
    "PARQUET_HEADER_KEY",
    "Prediction",
    "Submission",
    "SubmissionHeader",
    "load_schema",
    "write_submission",
]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
B = NDArray[np.bool_]

PARQUET_HEADER_KEY = "nsrmp_bench.header"
"""The Parquet schema-metadata key holding the header's JSON text."""

ABSTAIN_VALUES = ("no action", "not feasible")
"""The values of a line's ``abstain`` field: nothing is to move (a prohibition, a question,
a remark), or the instruction cannot be carried out (an absent or ambiguous referent)."""

ABSTAIN_CODES = {value: code for code, value in enumerate(ABSTAIN_VALUES, 1)}
"""``abstain`` value -> its code in :attr:`Submission.abstain` (0: no abstention)."""

_BOX_DECIMALS = 6  # pixels: below float32 precision of the gold boxes
_POS_DECIMALS = 6  # metres: micrometres


def load_schema() -> dict[str, Any]:
    """The JSON Schema of one predictions line (package data ``submission.schema.json``)."""
    text = (
        resources.files("nsrmp_bench.scoring")
        .joinpath("submission.schema.json")
        .read_text("utf-8")
    )
    schema: dict[str, Any] = json.loads(text)
    return schema


@dataclass(frozen=True)
class SubmissionHeader:
    """The first line of a predictions file: what it is for and who made it."""

    split: str
    scorer: str = WRITTEN_SCORER_ID
    model: str | None = None
    format: str = SUBMISSION_FORMAT
    format_version: str = BASE_FORMAT_VERSION
    extra: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The header object (the value of the first line's ``header`` key)."""
        out: dict[str, Any] = {
            "format": self.format,
            "format_version": self.format_version,
            "split": self.split,
            "scorer": self.scorer,
        }
        if self.model is not None:
            out["model"] = self.model
        out.update(self.extra)
        return out


def _round_list(values: ArrayLike, decimals: int, where: str) -> Any:
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        msg = f"{where} must hold numbers, got {values!r:.60}"
        raise InvalidArgument(msg) from exc
    if not np.isfinite(arr).all():
        msg = f"{where} holds NaN or infinity; predictions must be finite numbers"
        raise InvalidArgument(msg)
    return np.round(arr, decimals).tolist()


@dataclass(frozen=True, eq=False)
class Prediction:
    """One instance's prediction, as a model or baseline writes it."""

    id: str
    boxes: NDArray[Any]  # (N, 4) pixel xyxy
    program: tuple[GroundedStep, ...] | None = None
    step_boxes: NDArray[Any] | None = None  # (S, N, 4)
    pick: tuple[float, float] | None = None
    place: tuple[float, float] | None = None
    positions: NDArray[Any] | None = None  # (N, 3) metres
    detections: NDArray[Any] | None = None  # (K, 4): boxes etc. are per detection
    abstain: str | None = None  # "no action" | "not feasible" (ABSTAIN_VALUES); None: acts

    def to_record(self) -> dict[str, Any]:
        """The JSON-able line (pixels and metres rounded to 6 decimals).

        Raises :class:`InvalidArgument` naming the instance and field for a value that is
        not a finite number (the file could not be written as strict JSON).
        """
        w = f"prediction {self.id!r}:"
        rec: dict[str, Any] = {
            "id": self.id, "boxes": _round_list(self.boxes, _BOX_DECIMALS, f"{w} boxes")
        }
        if self.program is not None:
            rec["program"] = [s.to_list() for s in self.program]
        for name, value, decimals in (
            ("step_boxes", self.step_boxes, _BOX_DECIMALS),
            ("pick", self.pick, _BOX_DECIMALS),
            ("place", self.place, _BOX_DECIMALS),
            ("positions", self.positions, _POS_DECIMALS),
            ("detections", self.detections, _BOX_DECIMALS),
        ):
            if value is not None:
                rec[name] = _round_list(value, decimals, f"{w} {name}")
        if self.abstain is not None:
            rec["abstain"] = self.abstain
        return rec


@dataclass(frozen=True, eq=False)
class Submission:
    """A parsed, format-checked predictions file: one row per record, flat arrays.

    Made by :func:`nsrmp_bench.scoring.reader.read_submission` (or
    :func:`nsrmp_bench.scoring.validate.parse_predictions`); not yet matched to a split's
    instances.
    """

    header: SubmissionHeader
    source: str
    ids: tuple[str, ...]
    lines: I64  # (R,) line (JSON Lines) or row (Parquet) number, 1-based
    obj_offsets: I64  # (R+1,)
    boxes: F64  # (O, 4)
    has_step_boxes: B  # (R,)
    n_step_states: I64  # (R,) number of per-step box lists (0 where absent)
    stepbox_offsets: I64  # (R+1,) over n_step_states * N
    step_boxes: F64  # (Q, 4)
    has_program: B  # (R,)
    program_offsets: I64  # (R+1,)
    actions: NDArray[np.int8]  # (U,) index into ACTIONS
    subjects: I64  # (U,)
    references: I64  # (U,)
    pick: F64  # (R, 2), NaN where absent
    place: F64  # (R, 2), NaN where absent
    has_positions: B  # (R,)
    positions: F64  # (O, 3), NaN where absent
    line_label: str = "line"
    has_detections: B | None = None  # (R,) the line is in the detected-objects protocol
    detections: F64 | None = None  # (O, 4) detected initial boxes, zeros where absent
    object_matched: B | None = None  # (O,) after resolution: the gold object was detected
    abstain: NDArray[np.int8] | None = None  # (R,) 0 none, 1 no action, 2 not feasible

    @property
    def abstain_codes(self) -> NDArray[np.int8]:
        """(R,) each record's abstain code (:data:`ABSTAIN_CODES`; 0 where none)."""
        if self.abstain is None:
            return np.zeros(len(self.ids), dtype=np.int8)
        return self.abstain

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def n_objects(self) -> I64:
        """Boxes per record."""
        out: I64 = np.diff(self.obj_offsets)
        return out

    def where(self, record: int) -> str:
        """``"line 12"`` (or ``"row 12"``) for record index ``record``."""
        return f"{self.line_label} {int(self.lines[record])}"


def write_submission(
    path: str | Path, header: SubmissionHeader, predictions: Iterable[Prediction]
) -> Path:
    """Write a predictions file atomically, in the format its suffix names: ``.jsonl``,
    ``.jsonl.gz`` (gzip-compressed JSON Lines) or ``.parquet``
    (:mod:`~nsrmp_bench.scoring.file_formats`)."""
    out = Path(path)
    fmt = written_format(out)
    records = [p.to_record() for p in predictions]
    if any("abstain" in r for r in records):
        header = header_for_abstain(header)
    if fmt is PredictionsFormat.PARQUET:
        from nsrmp_bench._optional import require

        pa = require("pyarrow")
        pq = require("pyarrow.parquet")
        table = _parquet_table(pa, header, records)
        with atomic_path(out) as tmp:
            pq.write_table(table, tmp)
        return out
    if fmt is PredictionsFormat.JSONL_GZ:
        lines = io.StringIO()
        _write_jsonl(lines, header, records)
        return write_jsonl_bytes(out, lines.getvalue().encode("utf-8"))
    with atomic_open(out) as fh:
        _write_jsonl(fh, header, records)
    return out


def header_for_abstain(header: SubmissionHeader) -> SubmissionHeader:
    """The header of a file whose lines use ``abstain``: format 1.1.0 at least, and a
    header (and its protocol) written for ``scorer-v1`` is written for ``scorer-v2``,
    which scores abstention (a file without ``abstain`` keeps the 1.0.0 / ``scorer-v1``
    header it was always written with)."""
    version = header.format_version
    if tuple(map(_int, version.split("."))) < tuple(map(_int, ABSTAIN_FORMAT_VERSION.split("."))):
        version = ABSTAIN_FORMAT_VERSION
    if header.scorer != WRITTEN_SCORER_ID:
        return replace(header, format_version=version)
    extra = dict(header.extra)
    protocol = extra.get("protocol")
    if isinstance(protocol, Mapping) and protocol.get("scorer") == WRITTEN_SCORER_ID:
        extra["protocol"] = {**protocol, "scorer": ABSTAIN_SCORER_ID}
    return replace(header, scorer=ABSTAIN_SCORER_ID, format_version=version, extra=extra)


def _int(text: str) -> int:
    return int(text) if text.isdigit() else 0


def _write_jsonl(fh: TextIO, header: SubmissionHeader, records: Iterable[dict[str, Any]]) -> None:
    """The header line, then one line per prediction record."""
    fh.write(json.dumps({"header": header.to_dict()}, allow_nan=False) + "\n")
    for rec in records:
        fh.write(json.dumps(rec, allow_nan=False, separators=(",", ":")))
        fh.write("\n")


PARQUET_COLUMNS = ("id", "boxes", "program", "step_boxes", "pick", "place", "positions",
                   "detections", "abstain")
"""The columns of a Parquet predictions file (one row per instance)."""


def _parquet_table(pa: ModuleType, header: SubmissionHeader, records: list[dict[str, Any]]) -> Any:
    """An Arrow table of the records; a program is a list of (action, subject, reference)."""
    rows = []
    # a file without abstain keeps the 1.0.0 columns (the same bytes as before 1.1.0)
    columns = [c for c in PARQUET_COLUMNS
               if c != "abstain" or any("abstain" in r for r in records)]
    for r in records:
        row = {c: r.get(c) for c in columns}
        if row["program"] is not None:
            row["program"] = [
                {"action": a, "subject": s, "reference": f} for a, s, f in row["program"]
            ]
        rows.append(row)
    step = pa.struct(
        [("action", pa.string()), ("subject", pa.int64()), ("reference", pa.int64())]
    )
    types = {
        "id": pa.string(),
        "boxes": pa.list_(pa.list_(pa.float64())),
        "program": pa.list_(step),
        "step_boxes": pa.list_(pa.list_(pa.list_(pa.float64()))),
        "pick": pa.list_(pa.float64()),
        "place": pa.list_(pa.float64()),
        "positions": pa.list_(pa.list_(pa.float64())),
        "detections": pa.list_(pa.list_(pa.float64())),
        "abstain": pa.string(),
    }
    schema = pa.schema(
        [(c, types[c]) for c in columns],
        metadata={PARQUET_HEADER_KEY: json.dumps(header.to_dict())},
    )
    return pa.Table.from_pylist(rows, schema=schema)
