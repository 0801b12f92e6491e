"""The official camera: facing the robot across the table, framed on the workspace."""

from __future__ import annotations

from nsrmp_bench.geometry.camera import Camera

__all__ = ["OFFICIAL_CAMERA", "official_camera"]

OFFICIAL_CAMERA = Camera(
    width=320,
    height=240,
    fov_y_deg=45.0,
    eye=(0.0, -0.78, 1.30),
    target=(0.0, 0.02, 0.625),
    near=0.05,
    far=4.0,
)
"""320x240 RGB; image-left is world -x and "behind" (+y) is away from the camera."""


def official_camera(width: int = 320, height: int = 240) -> Camera:
    """The official camera at the given image size."""
    return OFFICIAL_CAMERA.resized(width, height)
