"""Checking a predictions file without scoring it (``nsrmp-bench check-submission``).

Without data, the file's own consistency is checked: header, JSON, fields, types, finite
numbers, ordered boxes, programs, duplicate ids, and that it names the expected split.
With the split's data, also that every id belongs to the split, object and step counts
match, and boxes lie in the image; missing instances are counted.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from nsrmp_bench.errors import SubmissionError
from nsrmp_bench.scoring.align import align, split_matches
from nsrmp_bench.scoring.gold import load_gold
from nsrmp_bench.scoring.reader import read_submission_pending
from nsrmp_bench.scoring.scorer import Data
from nsrmp_bench.scoring.submission import SubmissionHeader
from nsrmp_bench.storage.split_root import part_of_split

__all__ = ["CheckReport", "check_submission"]


@dataclass(frozen=True)
class CheckReport:
    """What a successful check found."""

    source: str
    header: SubmissionHeader
    lines: int
    against_data: bool
    counts: dict[str, int] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    def summary(self) -> str:
        """One paragraph for people."""
        head = (
            f"{self.source}: valid predictions file for split {self.header.split!r} "
            f"({self.header.scorer}, format {self.header.format_version}), {self.lines} "
            "prediction(s)"
        )
        if not self.against_data:
            return (
                head + ". Ids, object counts and image bounds were not checked: pass --data "
                "with the split's data to check them."
            )
        c = self.counts
        text = (
            f"{head}; {c.get('predicted', 0)} of {c.get('instances', 0)} instances predicted, "
            f"{c.get('missing', 0)} missing (they score zero)."
        )
        return "\n".join([text, *(f"warning: {w}" for w in self.warnings)])


def check_submission(
    path: str | Path,
    *,
    split: str | None = None,
    data: Data | None = None,
    unknown_ids: str = "error",
) -> CheckReport:
    """Check a predictions file; raise :class:`SubmissionError` naming every problem."""
    sub, pending = read_submission_pending(path)
    if split is not None and not split_matches(split, sub.header.split):
        msg = (
            f"{sub.source}: the header says split {sub.header.split!r}, but you are checking it "
            f"for split {split!r}; write {split!r} in the header if the predictions are for it"
        )
        if pending.count:
            msg += "\n" + pending.message()
        raise SubmissionError(msg)
    if data is None:
        pending.raise_if_any()
        return CheckReport(sub.source, sub.header, len(sub), False)
    gold = load_gold(data, split=split, part=part_of_split(sub.header.split))
    table = align(sub, gold, unknown_ids=unknown_ids, pending=pending)
    return CheckReport(sub.source, sub.header, len(sub), True, table.counts, table.warnings)
