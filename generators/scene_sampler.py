"""Symbolic scene sampling: objects, colours, positions and yaws from an explicit Generator.

Objects are placed one after another at uniform positions in ``SAMPLING_AREA`` with a
uniform yaw; a candidate is kept when its circumscribed footprint circle clears every
placed object's by ``MIN_GAP``. (shape, colour) pairs are drawn from the allowed pairs with
replacement, so the same pair may occur twice: then only a relation can tell them apart.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from nsrmp_bench.config import ALL_PAIRS
from nsrmp_bench.errors import GenerationError, InvalidArgument
from nsrmp_bench.scene import Pose, Scene, SceneObject, yaw_quaternion
from nsrmp_bench.vocabulary import (
    EXTENTS,
    MAX_OBJECTS,
    MIN_OBJECTS,
    SAMPLING_AREA,
    TABLE_TOP_Z,
)

__all__ = ["ALL_PAIRS", "MAX_OBJECTS", "MIN_GAP", "MIN_OBJECTS", "sample_scene"]

MIN_GAP = 0.012
"""Clearance in metres between the circumscribed footprint circles of two objects."""
_TRIES_PER_OBJECT = 400
_RESTARTS = 50


def _radius(shape: str) -> float:
    ex, ey, _ = EXTENTS[shape]
    return math.hypot(ex, ey) / 2.0


def sample_scene(
    rng: np.random.Generator,
    n_objects: int,
    *,
    pairs: Sequence[tuple[str, str]] = ALL_PAIRS,
    duplicates: int = 0,
) -> Scene:
    """Sample a scene of ``n_objects`` objects.

    ``pairs`` restricts the (shape, colour) combinations (e.g. to hold some out);
    ``duplicates`` asks for at least that many objects that repeat an earlier object's pair.
    """
    if not MIN_OBJECTS <= n_objects <= MAX_OBJECTS:
        msg = f"n_objects={n_objects} is out of range; expected {MIN_OBJECTS}..{MAX_OBJECTS}"
        raise InvalidArgument(msg)
    if not pairs:
        msg = "pairs is empty; allow at least one (shape, colour) combination"
        raise InvalidArgument(msg)
    if not 0 <= duplicates < n_objects:
        msg = f"duplicates={duplicates} must be in 0..{n_objects - 1}"
        raise InvalidArgument(msg)
    chosen = [pairs[int(i)] for i in rng.integers(0, len(pairs), size=n_objects)]
    for k in range(duplicates):  # overwrite the last entries with copies of earlier ones
        chosen[n_objects - 1 - k] = chosen[int(rng.integers(0, n_objects - 1 - k))]
    objects = tuple(SceneObject(shape, colour) for shape, colour in chosen)
    area = SAMPLING_AREA
    for _ in range(_RESTARTS):
        placed: list[tuple[float, float, float]] = []  # x, y, radius
        poses: list[Pose] = []
        for obj in objects:
            r = _radius(obj.shape)
            for _ in range(_TRIES_PER_OBJECT):
                x = float(rng.uniform(area.x_min, area.x_max))
                y = float(rng.uniform(area.y_min, area.y_max))
                if all(math.hypot(x - px, y - py) >= r + pr + MIN_GAP for px, py, pr in placed):
                    break
            else:
                break  # could not place this object: restart the layout
            yaw = round(float(rng.uniform(0.0, math.pi / 2.0)), 4)
            placed.append((x, y, r))
            z = TABLE_TOP_Z + obj.extents[2] / 2.0
            poses.append(Pose((round(x, 5), round(y, 5), round(z, 6)), yaw_quaternion(yaw)))
        if len(poses) == n_objects:
            return Scene(objects, tuple(poses))
    msg = (
        f"could not place {n_objects} objects with {MIN_GAP} m clearance in the sampling "
        f"area after {_RESTARTS} restarts; use fewer objects"
    )
    raise GenerationError(msg)
