"""Results written as they come: a rollout's journal, from which a rerun resumes.

``<out>.journal`` holds a first line naming what the run is (split, policy, settings,
instance count) and then one line per finished instance: its predictions-file record and
its summary. Each line is flushed and fsynced before the next instance starts, so a
killed run loses at most the instance it was running; a line cut short by the kill is
dropped on reopening. A rerun with the same settings skips the instances the journal
holds; other settings are refused (the journal would mix two runs). When every instance is
done the predictions file is written atomically from the journal's records, in the part's
order, and the journal is removed: the file has the same bytes whether the run was
interrupted or not.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np

from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["RolloutJournal", "journal_path", "prediction_from_record"]


def journal_path(out: str | Path) -> Path:
    """Where the journal of a run writing ``out`` lives."""
    p = Path(out)
    return p.with_name(p.name + ".journal")


def prediction_from_record(record: Mapping[str, Any]) -> Prediction:
    """The :class:`Prediction` whose :meth:`~Prediction.to_record` is ``record``."""
    def arr(name: str) -> Any:
        value = record.get(name)
        return None if value is None else np.asarray(value, dtype=np.float64)

    def point(name: str) -> tuple[float, float] | None:
        value = record.get(name)
        return None if value is None else (float(value[0]), float(value[1]))

    program = record.get("program")
    return Prediction(
        id=str(record["id"]), boxes=np.asarray(record["boxes"], dtype=np.float64),
        program=None if program is None else tuple(GroundedStep.from_list(s) for s in program),
        step_boxes=arr("step_boxes"), pick=point("pick"), place=point("place"),
        positions=arr("positions"), detections=arr("detections"))


class RolloutJournal:
    """The journal of one run (see the module)."""

    def __init__(self, path: str | Path, run: Mapping[str, Any]) -> None:
        self.path = Path(path)
        self.run = json.loads(json.dumps(dict(run)))
        self.records: dict[str, dict[str, Any]] = {}
        self.summaries: dict[str, dict[str, Any]] = {}
        self._fh: IO[str] | None = None
        good = self._read() if self.path.exists() else 0
        if good:
            with self.path.open("r+b") as fh:  # drop a line the kill cut short
                fh.truncate(good)
            self._fh = self.path.open("a", encoding="utf-8")
        else:
            self._fh = self.path.open("w", encoding="utf-8")
            self._write({"journal": self.run})

    def _read(self) -> int:
        """Read the journal; the byte length of its complete, well-formed lines."""
        data = self.path.read_bytes()
        good = 0
        first = True
        for raw in data.splitlines(keepends=True):
            if not raw.endswith(b"\n"):
                break
            try:
                line = json.loads(raw)
            except ValueError:
                break
            if first:
                if not isinstance(line, dict) or line.get("journal") != self.run:
                    theirs = line.get("journal") if isinstance(line, dict) else line
                    msg = (f"{self.path} is the journal of another run ({theirs!r:.300}); this "
                           f"run is {self.run!r:.300}: rerun with that run's settings to "
                           "resume it, or delete the journal to start afresh")
                    raise InvalidArgument(msg)
                first = False
            else:
                rid = str(line["record"]["id"])
                self.records[rid] = line["record"]
                self.summaries[rid] = line["summary"]
            good += len(raw)
        return good

    def _write(self, line: Mapping[str, Any]) -> None:
        assert self._fh is not None
        self._fh.write(json.dumps(line, allow_nan=False, separators=(",", ":")) + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def add(self, prediction: Prediction, summary: Mapping[str, Any]) -> None:
        """Record one finished instance (durably, before returning)."""
        record = prediction.to_record()
        self._write({"record": record, "summary": dict(summary)})
        self.records[prediction.id] = record
        self.summaries[prediction.id] = dict(summary)

    def close(self) -> None:
        """Close the file (the journal stays, for a rerun to resume)."""
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def remove(self) -> None:
        """Close and delete the journal (the run's output is written)."""
        self.close()
        self.path.unlink(missing_ok=True)
