"""The robustness suite's table: one row per source and perturbation kind, read and
written as ``robustness.json`` and shown as a board (Markdown here, HTML on the site).

Made by :func:`nsrmp_bench.robustness.suite.run_suite`; every figure is the public
scorer's (IoU-M with its bootstrap interval) or ``compare``'s (the paired difference to the
same source on the unperturbed part, its interval and p-value).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.atomic import atomic_write_text

__all__ = ["SUITE_FORMAT", "KindRow", "Suite", "read_suite", "suite_from_dict"]

SUITE_FORMAT = "nsrmp-bench-robustness"


@dataclass(frozen=True)
class KindRow:
    """One source on one kind, against the same source on the unperturbed part."""

    source: str
    kind: str
    control: bool
    changed: int
    count: int
    iou_m: float
    iou_m_low: float
    iou_m_high: float
    clean_iou_m: float
    diff: float
    diff_low: float
    diff_high: float
    p_value: float
    program_exact: float
    clean_program_exact: float
    success: float
    success_strict: float = math.nan  # scorer-v2's, on the perturbed part (NaN: not scored)
    kept_still: float = math.nan
    clean_success_strict: float = math.nan  # the same on the unperturbed part
    clean_kept_still: float = math.nan


@dataclass(frozen=True)
class Suite:
    """The suite's table on one part."""

    split: str
    seed: int
    source_root_hash: str
    rows: tuple[KindRow, ...]

    @property
    def sources(self) -> list[str]:
        """The sources, in the order they were given."""
        return list(dict.fromkeys(r.source for r in self.rows))

    @property
    def kinds(self) -> list[str]:
        """The kinds, in the order the suite ran them."""
        return list(dict.fromkeys(r.kind for r in self.rows))

    @property
    def controls(self) -> list[str]:
        """The control kinds among :attr:`kinds` (blind, shuffled)."""
        return list(dict.fromkeys(r.kind for r in self.rows if r.control))

    def row(self, source: str, kind: str) -> KindRow | None:
        """The row of ``source`` on ``kind``, if run."""
        return next((r for r in self.rows if r.source == source and r.kind == kind), None)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (``robustness.json``; a table without ``scorer-v2``'s figures
        is written as before them)."""
        strict = self.has_strict
        return {"format": SUITE_FORMAT, "split": self.split, "seed": self.seed,
                "source_root_hash": self.source_root_hash,
                "rows": [_finite(_row_dict(r, strict)) for r in self.rows]}

    def write(self, path: str | os.PathLike[str]) -> Path:
        """Write the table as JSON (atomically)."""
        text = json.dumps(self.to_dict(), indent=1, sort_keys=True) + "\n"
        return atomic_write_text(path, text)

    @property
    def has_strict(self) -> bool:
        """Whether the rows hold ``scorer-v2``'s strict success and kept still (a table
        made before ``scorer-v2`` does not)."""
        return any(math.isfinite(r.clean_success_strict) for r in self.rows)

    def table(self) -> tuple[list[str], list[list[str]]]:
        """The board's header and rows of text: a row per source, its IoU-M on the
        unperturbed part (and, under ``scorer-v2``, its strict success and kept still
        there), per kind the paired IoU-M difference [95% interval], the controls apart
        (their IoU-M)."""
        controls = self.controls
        kinds = [k for k in self.kinds if k not in controls]
        strict = self.has_strict
        head = ["model", "IoU-M", *(["strict success", "kept still"] if strict else []),
                *kinds, *(f"{c} (IoU-M)" for c in controls)]
        rows = []
        for s in self.sources:
            first = next(r for r in self.rows if r.source == s)
            cells = [s, f"{first.clean_iou_m:.3f}"]
            if strict:
                cells += [_fmt(first.clean_success_strict), _fmt(first.clean_kept_still)]
            for k in kinds:
                r = self.row(s, k)
                cells.append("" if r is None else
                             f"{r.diff:+.3f} [{r.diff_low:+.3f}, {r.diff_high:+.3f}]")
            for k in controls:
                r = self.row(s, k)
                cells.append("" if r is None else f"{r.iou_m:.3f}")
            rows.append(cells)
        return head, rows

    def markdown(self) -> str:
        """The board as a Markdown table (:meth:`table`)."""
        head, rows = self.table()
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        lines += ["| " + " | ".join(cells) + " |" for cells in rows]
        return "\n".join(lines) + "\n"


_STRICT_FIELDS = ("success_strict", "kept_still", "clean_success_strict", "clean_kept_still")


def _row_dict(row: KindRow, strict: bool) -> dict[str, Any]:
    out = asdict(row)
    if not strict:
        for k in _STRICT_FIELDS:
            out.pop(k)
    return out


def _fmt(value: float) -> str:
    return f"{value:.3f}" if math.isfinite(value) else "–"


def _finite(row: dict[str, Any]) -> dict[str, Any]:
    return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in row.items()}


def suite_from_dict(data: dict[str, Any], where: str) -> Suite:
    """Inverse of :meth:`Suite.to_dict`."""
    if data.get("format") != SUITE_FORMAT:
        msg = f"{where} is not a robustness table (format {data.get('format')!r})"
        raise InvalidArgument(msg)
    rows = tuple(KindRow(**{k: (math.nan if v is None else v)  # type: ignore[arg-type]
                            for k, v in r.items()}) for r in data["rows"])
    return Suite(str(data["split"]), int(data["seed"]), str(data["source_root_hash"]), rows)


def read_suite(path: str | os.PathLike[str]) -> Suite:
    """Read a ``robustness.json``."""
    return suite_from_dict(json.loads(Path(path).read_text("utf-8")), str(path))
