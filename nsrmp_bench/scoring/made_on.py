"""Predictions are scored on the part they were made on.

A predictions header's ``protocol`` names the root hash of the manifest of the part the
predictions were made on (:mod:`~nsrmp_bench.scoring.protocol_fields`). ``score`` refuses a
file whose stated root hash is not the one of the data it is scored against, as
``check-submission`` and the leaderboard do; a deliberate cross-scoring (predictions made
on one part scored on a perturbed copy, say) says so with ``--allow-other-manifest``. A file
that states no protocol is scored (``check-submission`` warns about it).
"""

from __future__ import annotations

import os
from pathlib import Path

from nsrmp_bench.errors import InvalidArgument, SubmissionError
from nsrmp_bench.scoring.protocol_fields import ProtocolFields, manifest_mismatch, part_root_hash
from nsrmp_bench.scoring.reader import read_header
from nsrmp_bench.storage.split_root import part_of_split

__all__ = ["refuse_other_manifest"]


def refuse_other_manifest(predictions: str | os.PathLike[str],
                          data: str | os.PathLike[str]) -> None:
    """Raise :class:`SubmissionError` when ``predictions`` states a protocol made on another
    manifest than the part ``data`` holds; nothing when it states none, or when ``data`` has
    no manifest (a shard file, symbolic episodes) to compare."""
    path = Path(predictions)
    if not path.is_file() or not Path(data).exists():
        return  # reading or loading then names the problem
    header = read_header(path)
    raw = header.get("protocol")
    if raw is None:
        return
    try:
        fields = ProtocolFields.from_dict(raw, f"{path} header")
    except InvalidArgument as exc:
        raise SubmissionError(str(exc)) from exc
    split = header.get("split")
    part = split if isinstance(split, str) else str(data)
    try:
        root = part_root_hash(data, part_of_split(part))
    except InvalidArgument:
        return  # the part is not in the data: loading it names the problem
    if root is None:
        return
    problem = manifest_mismatch(fields, root, part, str(path))
    if problem is not None:
        msg = (f"{problem}; to score it on this part on purpose (cross-scoring), pass "
               "--allow-other-manifest")
        raise SubmissionError(msg)
