"""The detections file: per episode, the initial scene's detected objects.

JSON Lines. The first line is the header, each further line one episode::

    {"header": {"format": "nsrmp-bench-detections", "format_version": "1.0.0",
                "split": "paper-v2/test", "detector": "detector-v1"}}
    {"id": "paper-v2-test-000000", "boxes": [[x1, y1, x2, y2], ...],
     "scores": [0.98, ...], "shapes": ["cube", null, ...], "colours": ["red", ...]}

``boxes`` are amodal pixel xyxy boxes of the initial image, ``scores`` each detection's
confidence in [0, 1], ``shapes`` / ``colours`` what the detector sees (a name from the
vocabulary, or ``null`` when it does not say; the classical detector gives no shape).
Lists are in detection order (score descending); an episode with nothing detected has
empty lists. :func:`read_detections` refuses a bad file with one error naming every
problem with its line.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidArgument, SubmissionError
from nsrmp_bench.scoring.version import SUBMISSION_FORMAT
from nsrmp_bench.storage.atomic import atomic_open
from nsrmp_bench.vocabulary import COLOURS, SHAPES

__all__ = [
    "DETECTIONS_FORMAT",
    "DETECTIONS_FORMAT_VERSION",
    "DetectionFile",
    "Detections",
    "read_detections",
    "write_detections",
]

DETECTIONS_FORMAT = "nsrmp-bench-detections"
DETECTIONS_FORMAT_VERSION = "1.0.0"
_MAX_SHOWN = 20
_FIELDS = ("id", "boxes", "scores", "shapes", "colours")


@dataclass(frozen=True, eq=False)
class Detections:
    """One episode's detected initial objects."""

    id: str
    boxes: NDArray[np.float64]  # (K, 4) pixel xyxy
    scores: NDArray[np.float64]  # (K,)
    shapes: tuple[str | None, ...] = ()
    colours: tuple[str | None, ...] = ()

    def __post_init__(self) -> None:
        k = len(self.boxes)
        for name in ("shapes", "colours"):
            if not getattr(self, name):
                object.__setattr__(self, name, (None,) * k)

    def __len__(self) -> int:
        return len(self.boxes)

    def to_record(self) -> dict[str, Any]:
        """The JSON-able line (pixels to 3 decimals, scores to 4)."""
        return {"id": self.id,
                "boxes": np.round(np.asarray(self.boxes, float).reshape(-1, 4), 3).tolist(),
                "scores": np.round(np.asarray(self.scores, float), 4).tolist(),
                "shapes": list(self.shapes), "colours": list(self.colours)}


@dataclass(frozen=True)
class DetectionFile:
    """A read detections file: its header and the detections by episode id."""

    header: dict[str, Any]
    by_id: dict[str, Detections] = field(default_factory=dict)

    @property
    def detector(self) -> str:
        """The detector id the header names."""
        return str(self.header.get("detector", "unknown"))


def write_detections(path: str | Path, split: str, detector: str,
                     detections: Iterable[Detections],
                     extra: dict[str, Any] | None = None) -> Path:
    """Write a detections file atomically (``*.tmp``, fsync, rename)."""
    out = Path(path)
    if out.suffix not in (".jsonl", ".ndjson"):
        msg = f"detections file {str(out)!r}: use a .jsonl (JSON Lines) suffix"
        raise InvalidArgument(msg)
    header = {"format": DETECTIONS_FORMAT, "format_version": DETECTIONS_FORMAT_VERSION,
              "split": split, "detector": detector, **(extra or {})}
    with atomic_open(out) as fh:
        fh.write(json.dumps({"header": header}) + "\n")
        for d in detections:
            fh.write(json.dumps(d.to_record(), separators=(",", ":")) + "\n")
    return out


def _line_problems(n: int, rec: object) -> Iterator[str]:
    where = f"line {n}"
    if not isinstance(rec, dict):
        yield f"{where}: expected a JSON object, got {type(rec).__name__}"
        return
    unknown = sorted(set(rec) - set(_FIELDS))
    if unknown:
        yield f"{where}: unknown field(s) {unknown}; expected {list(_FIELDS)}"
    if not isinstance(rec.get("id"), str) or not rec.get("id"):
        yield f"{where}: 'id' must be a non-empty string, got {rec.get('id')!r}"
    boxes = rec.get("boxes")
    if not isinstance(boxes, list):
        yield f"{where}: 'boxes' must be a list of [x1, y1, x2, y2], got {boxes!r:.60}"
        return
    for j, b in enumerate(boxes):
        if (not isinstance(b, list) or len(b) != 4
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                           and math.isfinite(v) for v in b)):
            yield f"{where}: boxes[{j}] must be 4 finite numbers [x1, y1, x2, y2], got {b!r:.60}"
        elif b[2] < b[0] or b[3] < b[1]:
            yield f"{where}: boxes[{j}] {b} has x2 < x1 or y2 < y1; write [x1, y1, x2, y2]"
    scores = rec.get("scores")
    if (not isinstance(scores, list) or len(scores) != len(boxes)
            or not all(isinstance(s, (int, float)) and not isinstance(s, bool)
                       and 0.0 <= s <= 1.0 for s in scores)):
        yield (f"{where}: 'scores' must be {len(boxes)} numbers in [0, 1] (one per box), "
               f"got {scores!r:.60}")
    for name, allowed in (("shapes", SHAPES), ("colours", COLOURS)):
        vals = rec.get(name)
        if vals is None:
            continue
        if not isinstance(vals, list) or len(vals) != len(boxes):
            yield f"{where}: '{name}' must list one name or null per box, got {vals!r:.60}"
            continue
        bad = [v for v in vals if v is not None and v not in allowed]
        if bad:
            yield f"{where}: '{name}' holds {bad[0]!r}; expected one of {list(allowed)} or null"


def read_detections(path: str | Path) -> DetectionFile:
    """Read and check a detections file; one :class:`SubmissionError` lists every problem."""
    p = Path(path)
    if not p.is_file():
        msg = (f"detections file {str(p)!r} does not exist; write one with "
               "`nsrmp-bench detect --data DATA --out detections.jsonl`")
        raise InvalidArgument(msg)
    problems: list[str] = []
    header: dict[str, Any] = {}
    by_id: dict[str, Detections] = {}
    with p.open(encoding="utf-8") as fh:
        for n, raw in enumerate(fh, start=1):
            if not raw.strip():
                continue
            try:
                rec = json.loads(raw)
            except json.JSONDecodeError as exc:
                problems.append(f"line {n}: invalid JSON ({exc.msg}); write one object a line")
                continue
            if n == 1:
                h = rec.get("header") if isinstance(rec, dict) else None
                if isinstance(h, dict) and h.get("format") == SUBMISSION_FORMAT:
                    msg = (f"{p} is a predictions file (format {SUBMISSION_FORMAT!r}), not a "
                           "detections file; make detections of the part with `nsrmp-bench "
                           "detect --data DATA --out detections.jsonl` and pass that")
                    raise InvalidArgument(msg)
                if not isinstance(h, dict) or h.get("format") != DETECTIONS_FORMAT:
                    problems.append(
                        f"line 1: expected the header {{\"header\": {{\"format\": "
                        f"\"{DETECTIONS_FORMAT}\", ...}}}}, got {raw.strip()!r:.80}")
                else:
                    major = str(h.get("format_version", "")).split(".")[0]
                    if major != DETECTIONS_FORMAT_VERSION.split(".")[0]:
                        problems.append(
                            f"line 1: format_version {h.get('format_version')!r} is not one "
                            f"this reader knows ({DETECTIONS_FORMAT_VERSION}); upgrade "
                            "nsrmp-bench or rewrite the file")
                    header = h
                continue
            found = list(_line_problems(n, rec))
            if found:
                problems.extend(found)
                continue
            eid = rec["id"]
            if eid in by_id:
                problems.append(f"line {n}: duplicate id {eid!r}; give each episode one line")
                continue
            k = len(rec["boxes"])
            by_id[eid] = Detections(
                eid, np.asarray(rec["boxes"], dtype=np.float64).reshape(k, 4),
                np.asarray(rec["scores"], dtype=np.float64),
                tuple(rec.get("shapes") or (None,) * k), tuple(rec.get("colours") or (None,) * k))
    if not header and not problems:
        problems.append("line 1: the file is empty; it needs a header line")
    if problems:
        shown = "\n  ".join(problems[:_MAX_SHOWN])
        extra = len(problems) - _MAX_SHOWN
        more = f"\n  ... and {extra} more" if extra > 0 else ""
        msg = f"{p}: {len(problems)} problem(s) in the detections file:\n  {shown}{more}"
        raise SubmissionError(msg)
    return DetectionFile(header, by_id)
