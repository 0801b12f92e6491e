"""States to amodal 2D boxes: the projection of object poses through a camera.

The projection turns any state (an episode's symbolic states, or one predicted by the oracle
or random baseline) into boxes; what an episode looks like from its own camera is
:mod:`nsrmp_bench.episode_views`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.scene import SceneObject, State

__all__ = ["states_boxes"]


def states_boxes(
    camera: Camera, objects: Sequence[SceneObject], states: Sequence[State]
) -> NDArray[np.float64]:
    """Amodal boxes ``(len(states), N, 4)`` of every object in every state."""
    n = len(objects)
    extents = np.array([o.extents for o in objects], dtype=np.float64).reshape(n, 3)
    pos = np.array([[p.position for p in s] for s in states], dtype=np.float64)
    orn = np.array([[p.orientation for p in s] for s in states], dtype=np.float64)
    k = len(states)
    boxes = camera.amodal_boxes(
        np.tile(extents, (k, 1)), pos.reshape(k * n, 3), orn.reshape(k * n, 4)
    )
    return boxes.astype(np.float64).reshape(k, n, 4)
