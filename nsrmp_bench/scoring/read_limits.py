"""How much a predictions file may hold, derived from the part it claims to be for.

A predictions file arrives from outside; reading it is bounded by its part, so that no
file (a gzip bomb, gigabytes of newlines, a Parquet file whose pages expand a thousandfold)
can make a reader use more than a valid file's memory and time:

* **lines**: at most one per instance, plus the header (blank lines are not counted, but
  their bytes are);
* **a line's bytes**: the budget of the part's largest instance;
* **the file's bytes**, decompressed: the sum of every instance's budget, plus the header's;
* **numbers** (Parquet's leaf values): the sum of every instance's number budget.

An instance's budget is generous: room for one box per object *or per detection* (up to
twice the objects plus 8) in ``boxes``, every step of ``step_boxes``, ``detections`` and
``positions``, a program twice the gold length plus 8 steps, pick and place, each number
written with up to :data:`NUMBER_BYTES` characters, plus :data:`LINE_OVERHEAD` bytes of
id, keys and free fields. A valid file uses a tenth of it or less.

The part is known from the data being scored against (its gold), else from the committed
manifest of the official split the header names; a file for a part known neither way is
read under :meth:`ReadLimits.unknown_part`'s fixed bounds, which the message names.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from nsrmp_bench.errors import NSRMPError
from nsrmp_bench.official_manifests import official_manifest
from nsrmp_bench.split_specs import load_split

__all__ = ["HEADER_BYTES", "LINE_OVERHEAD", "NUMBER_BYTES", "ReadLimits"]

NUMBER_BYTES = 32
"""Characters a number may take in JSON (``-123.45678901234567e-05`` and its comma)."""
LINE_OVERHEAD = 2048
"""Bytes of a line beyond its numbers: the id, the keys, free fields."""
HEADER_BYTES = 64 * 1024
"""Bytes the header line may take (it holds the protocol and free fields)."""
UNKNOWN_INSTANCES = 1_000_000
"""Lines allowed in a file for a part that is not known (no data, no committed manifest)."""
UNKNOWN_LINE_BYTES = 1024 * 1024
UNKNOWN_FILE_BYTES = 512 * 1024 * 1024


def instance_numbers(objects: int, steps: int) -> int:
    """The numbers one instance's line may hold (see the module doc)."""
    boxes = 2 * objects + 8  # objects or detections
    per_box = 4 * (1 + steps + 1) + 3  # boxes, step_boxes, detections; positions
    program = 3 * (2 * steps + 8)
    return boxes * per_box + program + 4


def instance_bytes(objects: int, steps: int) -> int:
    """The bytes one instance's line may take."""
    return LINE_OVERHEAD + NUMBER_BYTES * instance_numbers(objects, steps)


@dataclass(frozen=True)
class ReadLimits:
    """The bounds reading one predictions file keeps to."""

    instances: int
    """Prediction lines allowed (the header is one more)."""
    line_bytes: int
    """Bytes one line may take (the header: :data:`HEADER_BYTES`)."""
    file_bytes: int
    """Bytes the whole file may take, decompressed."""
    numbers: int
    """Numbers the whole file may hold (Parquet's leaf values)."""
    part: str
    """What the bounds were derived from, for the messages (``paper-v2/test``)."""

    @property
    def lines(self) -> int:
        """Non-blank lines allowed: the instances and the header."""
        return self.instances + 1

    @classmethod
    def for_instances(cls, part: str, sizes: Iterable[tuple[int, int]]) -> ReadLimits:
        """Bounds of a part whose instances have ``(objects, steps)`` ``sizes``."""
        count = line = total = numbers = 0
        for objects, steps in sizes:
            count += 1
            size = instance_bytes(objects, steps)
            line = max(line, size)
            total += size
            numbers += instance_numbers(objects, steps)
        return cls(instances=count, line_bytes=max(line, HEADER_BYTES),
                   file_bytes=total + HEADER_BYTES, numbers=numbers, part=part)

    @classmethod
    def for_arrays(cls, part: str, objects: Any, steps: Any) -> ReadLimits:
        """Bounds of a part given its per-instance object and step counts (two integer
        arrays, e.g. a gold table's ``n_objects`` and ``n_steps``)."""
        return cls.for_instances(part, zip(objects.tolist(), steps.tolist(), strict=True))

    @classmethod
    def unknown_part(cls) -> ReadLimits:
        """Fixed bounds for a file whose part is not known here."""
        return cls(instances=UNKNOWN_INSTANCES, line_bytes=UNKNOWN_LINE_BYTES,
                   file_bytes=UNKNOWN_FILE_BYTES,
                   numbers=UNKNOWN_FILE_BYTES // NUMBER_BYTES, part="")

    @classmethod
    def committed(cls, split: str) -> ReadLimits | None:
        """Bounds from the committed manifest(s) of the official split ``split`` names
        (every part when it names none); None when there is none."""
        split_id, _, part = split.partition("/")
        try:
            parts = [part] if part else list(load_split(split_id).parts)
            manifests = [official_manifest(split_id, p) for p in parts]
        except (NSRMPError, OSError, ValueError):
            return None
        if any(m is None for m in manifests):
            return None
        sizes = [(int(e["objects"]), int(e["steps"]))
                 for m in manifests if m is not None for e in m["episodes"]]
        return cls.for_instances(split, sizes)

    def describe(self) -> str:
        """Where the bounds come from, for a message."""
        if self.part:
            return f"the {self.instances} instances of {self.part}"
        return ("the fixed bounds for a part not known here (pass the part's data to read "
                "it under that part's own bounds)")
