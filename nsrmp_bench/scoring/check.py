"""Checking a predictions file without scoring it (``nsrmp-bench check-submission``).

Without data, the file's own consistency is checked: header, JSON, fields, types, finite
numbers, ordered boxes, programs, duplicate ids, and that it names the expected split; for
an official split the committed manifest (shipped with the package) holds every instance's
id and object count, so ids and box counts are checked and missing instances counted too.
With the split's data, also step counts and that boxes lie in the image; with an
inputs-only pack (what a challenge's participants hold), ids, object counts, image bounds
and the root hash (:mod:`~nsrmp_bench.scoring.inputs_only_check`). A file that
predicts no instance at all is refused (it would score zero).

The header's ``"protocol"`` (:mod:`nsrmp_bench.scoring.protocol_fields`) is checked field by
field, and its manifest root hash against the part's (the data's manifest, else the
committed one): a file made on another manifest is refused. A file without it is valid
with a warning (the leaderboard requires it).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from nsrmp_bench.errors import InvalidArgument, NSRMPError, SubmissionError
from nsrmp_bench.official_manifests import official_manifest
from nsrmp_bench.scoring.align import align, split_matches
from nsrmp_bench.scoring.gold import GoldTable, load_gold
from nsrmp_bench.scoring.inputs_only_check import check_image_bounds, inputs_only_part
from nsrmp_bench.scoring.protocol_fields import (
    PROTOCOL_KEYS,
    ProtocolFields,
    manifest_mismatch,
    part_root_hash,
)
from nsrmp_bench.scoring.reader import claimed_split, read_submission_pending
from nsrmp_bench.scoring.scorer import Data, gold_limits
from nsrmp_bench.scoring.submission import Submission, SubmissionHeader
from nsrmp_bench.scoring.validate import Problems
from nsrmp_bench.split_specs import load_split
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
    against_manifest: str = ""
    protocol: str = ""
    """What the protocol check found (one sentence), or a warning that there is none."""
    inputs_only: bool = False
    """Checked against an inputs-only pack's manifest and inputs (ids, counts, bounds)."""

    def summary(self) -> str:
        """One paragraph for people, and the protocol check's line."""
        text = self._counts_summary()
        return f"{text}\n{self.protocol}" if self.protocol else text

    def _counts_summary(self) -> str:
        head = (
            f"{self.source}: valid predictions file for split {self.header.split!r} "
            f"({self.header.scorer}, format {self.header.format_version}), {self.lines} "
            "prediction(s)"
        )
        c = self.counts
        if self.inputs_only:
            return (
                f"{head}; {c.get('predicted', 0)} of {c.get('instances', 0)} instances "
                f"predicted, {c.get('missing', 0)} missing (they score zero). Ids, object "
                f"counts and image bounds were checked against the inputs-only pack of "
                f"{self.against_manifest}; step counts need the full part."
            )
        if not self.against_data and self.against_manifest:
            return (
                f"{head}; {c.get('predicted', 0)} of {c.get('instances', 0)} instances "
                f"predicted, {c.get('missing', 0)} missing (they score zero). Ids and object "
                f"counts were checked against the committed manifest of "
                f"{self.against_manifest}; pass --data with the split's data to check step "
                "counts and image bounds too."
            )
        if not self.against_data:
            return (
                head + ". Ids, object counts and image bounds were not checked: pass --data "
                "with the split's data to check them."
            )
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
    """Check a predictions file; raise :class:`SubmissionError` naming every problem.

    The file is read within the bounds of its part: the data's when given, else the
    committed manifest's (:mod:`~nsrmp_bench.scoring.read_limits`)."""
    pack = None if data is None else inputs_only_part(data, split or claimed_split(path) or "")
    gold = None if pack is not None else _gold_of_claimed_part(path, split, data)
    sub, pending = read_submission_pending(
        path, limits=None if gold is None else gold_limits(gold, unknown_ids))
    if split is not None and not split_matches(split, sub.header.split):
        msg = (
            f"{sub.source}: the header says split {sub.header.split!r}, but you are checking it "
            f"for split {split!r}; "
            + (f"write {split!r} in the header if the predictions are for it"
               if _is_known_split(split) else
               f"{split!r} is not a shipped split: check it for the one it was made on "
               f"(--split {sub.header.split})")
        )
        if pending.count:
            msg += "\n" + pending.message()
        raise SubmissionError(msg)
    if not len(sub) and not pending.count:
        msg = (f"{sub.source}: holds a header but no prediction; every instance would score "
               "zero: write one line per instance after the header")
        raise SubmissionError(msg)
    protocol = _check_protocol(sub, data)
    if data is None:
        known = _committed_instances(sub.header.split)
        if known is None:
            pending.raise_if_any()
            return CheckReport(sub.source, sub.header, len(sub), False, protocol=protocol)
        name, objects = known
        counts = _check_with_manifest(sub, name, objects, unknown_ids, pending)
        pending.raise_if_any()
        return CheckReport(sub.source, sub.header, len(sub), False, counts,
                           against_manifest=name, protocol=protocol)
    if pack is not None:  # a participant's pack: ids, counts, bounds, root hash
        counts = _check_with_manifest(sub, pack.split, pack.objects, unknown_ids, pending)
        if pack.image_size is not None:
            check_image_bounds(sub, pack.image_size, pending)
        pending.raise_if_any()
        return CheckReport(sub.source, sub.header, len(sub), False, counts,
                           against_manifest=pack.split, protocol=protocol, inputs_only=True)
    if gold is None:  # the same header: the part read above, when there was one
        gold = load_gold(data, split=split, part=part_of_split(sub.header.split))
    table = align(sub, gold, unknown_ids=unknown_ids, pending=pending)
    return CheckReport(sub.source, sub.header, len(sub), True, table.counts, table.warnings,
                       protocol=protocol)


def _gold_of_claimed_part(path: str | Path, split: str | None, data: Data | None
                          ) -> GoldTable | None:
    """The gold of the part the file's header names, when data is given and holds it (its
    instances bound the reading); None otherwise (the reading then names the problem)."""
    if data is None:
        return None
    claimed = claimed_split(path)
    if claimed is None:
        return None
    try:
        return load_gold(data, split=split, part=part_of_split(claimed))
    except NSRMPError:
        return None


def _part_root_hash(split: str, data: Data | None) -> str | None:
    """The root hash of the part ``split`` names: of the data's manifest when given as a
    folder, else of the committed manifest of an official split; None when unknown."""
    if isinstance(data, str | Path):
        return part_root_hash(data, part_of_split(split))
    if data is not None:
        return None
    split_id, _, part = split.partition("/")
    if not part:
        return None
    try:
        committed = official_manifest(split_id, part)
    except NSRMPError:
        return None
    return None if committed is None else str(committed["root_hash"])


def _check_protocol(sub: Submission, data: Data | None) -> str:
    """Check the header's ``protocol``; returns the line the summary prints."""
    raw: object = sub.header.extra.get("protocol")
    if raw is None:
        return ("warning: the header states no \"protocol\" (supervision, boxes, training "
                "parts, seeds, scorer, manifest root hash); the leaderboard requires it: "
                "see docs/challenge.md")
    try:
        fields = ProtocolFields.from_dict(raw, f"{sub.source} header")
    except InvalidArgument as exc:
        raise SubmissionError(str(exc)) from exc
    if fields.scorer != sub.header.scorer:
        msg = (f"{sub.source}: the protocol's scorer is {fields.scorer!r} but the header's is "
               f"{sub.header.scorer!r}; state the same scorer in both")
        raise SubmissionError(msg)
    root = _part_root_hash(sub.header.split, data)
    if root is None:
        return (f"protocol: {len(PROTOCOL_KEYS)} fields valid; the manifest root hash "
                f"({fields.manifest_root_hash[:16]}...) was not compared: pass --data with "
                "the part's folder")
    problem = manifest_mismatch(fields, root, sub.header.split, sub.source)
    if problem is not None:
        raise SubmissionError(problem)
    return (f"protocol: {len(PROTOCOL_KEYS)} fields valid, made on the manifest of "
            f"{sub.header.split} (root hash {root[:16]}...)")


def _committed_instances(split: str) -> tuple[str, dict[str, int]] | None:
    """``(split, id -> object count)`` from the committed manifests of an official split
    (every part when ``split`` names none); None when there are none."""
    split_id, _, part = split.partition("/")
    try:
        parts = [part] if part else list(load_split(split_id).parts)
    except NSRMPError:  # not a shipped split: nothing committed
        return None
    objects: dict[str, int] = {}
    for p in parts:
        manifest = official_manifest(split_id, p)
        if manifest is None:
            return None
        objects.update({str(e["id"]): int(e["objects"]) for e in manifest["episodes"]})
    return split, objects


def _check_with_manifest(sub: Submission, split: str, objects: dict[str, int],
                         unknown_ids: str, problems: Problems) -> dict[str, int]:
    """Ids and box counts against the committed manifest; returns the counts."""
    detected = (sub.has_detections if sub.has_detections is not None
                else np.zeros(len(sub), bool))
    unknown = 0
    predicted = set()
    for r, eid in enumerate(sub.ids):
        n_gold = objects.get(eid)
        if n_gold is None:
            unknown += 1
            if unknown_ids == "error":
                problems.add(sub.where(r), f"id {eid!r} is not an instance of {split}; remove "
                             "the line (or check with unknown ids ignored: --allow-unknown-ids)")
            continue
        predicted.add(eid)
        n = int(sub.n_objects[r])
        if not detected[r] and n != n_gold:
            problems.add(sub.where(r), f"'boxes' has {n} boxes but instance {eid!r} has "
                         f"{n_gold} objects; give one box per object, in the episode's object "
                         "order")
    return {"instances": len(objects), "predicted": len(predicted),
            "missing": len(objects) - len(predicted), "unknown_ids": unknown}


def _is_known_split(split: str) -> bool:
    try:
        load_split(split.partition("/")[0])
    except NSRMPError:
        return False
    return True
