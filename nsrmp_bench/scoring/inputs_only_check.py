"""Checking a predictions file against an inputs-only pack, the part a challenge's
participants hold (``check-submission --data PACK``).

A pack (:mod:`nsrmp_bench.storage.inputs_only`) has no gold, but its manifest holds every
instance's id and object count and the part's root hash, and its inputs hold the camera:
so the file's ids, box counts and image bounds are checked, and its protocol's root hash
(by :func:`nsrmp_bench.scoring.check.check_submission`, from the pack's manifest). Step
counts need the gold and are not checked.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nsrmp_bench.errors import NSRMPError
from nsrmp_bench.scoring.align import CLIP_TOLERANCE
from nsrmp_bench.scoring.ragged import row_ids
from nsrmp_bench.scoring.submission import Submission
from nsrmp_bench.scoring.validate import MAX_SHOWN, Problems
from nsrmp_bench.storage.manifest import MANIFEST_NAME, read_manifest
from nsrmp_bench.storage.split_root import part_of_split, resolve_part

__all__ = ["InputsOnlyPart", "check_image_bounds", "inputs_only_part"]


@dataclass(frozen=True)
class InputsOnlyPart:
    """What an inputs-only pack tells about its part."""

    split: str
    objects: dict[str, int]
    image_size: tuple[int, int] | None


def inputs_only_part(data: object, split: str) -> InputsOnlyPart | None:
    """The pack ``data`` (a folder, or a split root at the part ``split`` names) when it is
    an inputs-only pack; None for anything else (full data, a file, no manifest)."""
    if not isinstance(data, str | os.PathLike):
        return None
    try:
        folder = resolve_part(Path(data), part_of_split(split))
        if not (folder / MANIFEST_NAME).is_file():
            return None
        manifest = read_manifest(folder)
    except NSRMPError:
        return None
    if not manifest.inputs_only:
        return None
    objects = {e.id: int(e.categories["objects"]) for s in manifest.shards for e in s.episodes}
    from nsrmp_bench.storage import open as open_storage

    size = None
    with open_storage(folder) as collection:
        if len(collection):
            camera = collection.read_inputs(0, images=False).get("camera")
            size = (int(camera.width), int(camera.height)) if camera is not None else None
    return InputsOnlyPart(manifest.split, objects, size)


def check_image_bounds(sub: Submission, size: tuple[int, int], problems: Problems) -> None:
    """Boxes more than :data:`~nsrmp_bench.scoring.align.CLIP_TOLERANCE` pixels outside the
    ``size`` image are problems, named by line."""
    width, height = size
    boxes = sub.boxes
    if not len(boxes):
        return
    low = np.fmin(np.fmin(boxes[:, 0], boxes[:, 1]), np.fmin(boxes[:, 2], boxes[:, 3]))
    far = ((low < -CLIP_TOLERANCE) | (np.fmax(boxes[:, 0], boxes[:, 2]) > width + CLIP_TOLERANCE)
           | (np.fmax(boxes[:, 1], boxes[:, 3]) > height + CLIP_TOLERANCE))
    record = row_ids(sub.obj_offsets)
    rows = np.flatnonzero(far)
    for row in rows[:MAX_SHOWN].tolist():
        r = int(record[row])
        k = row - int(sub.obj_offsets[r])
        problems.add(sub.where(r),
                     f"boxes[{k}] = {[float(v) for v in boxes[row]]} lies outside the "
                     f"{width}x{height} image; boxes are pixel [x1, y1, x2, y2] with "
                     f"0 <= x <= {width} and 0 <= y <= {height}")
    problems.count += max(0, len(rows) - MAX_SHOWN)
