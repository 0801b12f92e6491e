"""Height above the table top of every pixel, from the depth image and the camera.

Both detectors read it: the classical one thresholds it, the learned one takes it as an
input channel. A pixel's world point is its depth back-projected through the episode's
camera (:meth:`~nsrmp_bench.geometry.camera.Camera.backproject`, pixel centres at
``u + 0.5``); its height is that point's ``z`` minus ``TABLE_TOP_Z``. The floor beyond the
table comes out negative, objects positive (a 5 cm cube's top at about 0.05 m).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.vocabulary import TABLE_TOP_Z

__all__ = ["height_map", "world_points"]


def world_points(depth: NDArray[Any], camera: Camera) -> NDArray[np.float64]:
    """(H, W, 3) world point of each pixel of ``depth`` (H, W) metres."""
    d = np.asarray(depth, dtype=np.float64)
    if d.shape != (camera.height, camera.width):
        msg = (f"depth image of shape {d.shape} does not match the camera's "
               f"{camera.height}x{camera.width}; pass the episode's own depth and camera")
        raise InvalidArgument(msg)
    v, u = np.mgrid[0 : camera.height, 0 : camera.width].astype(np.float64)
    return camera.backproject(np.stack([u + 0.5, v + 0.5], axis=-1), d)


def height_map(depth: NDArray[Any], camera: Camera) -> NDArray[np.float32]:
    """(H, W) metres above the table top of each pixel of ``depth`` (H, W) metres."""
    return (world_points(depth, camera)[..., 2] - TABLE_TOP_Z).astype(np.float32)
