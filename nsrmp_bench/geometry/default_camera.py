"""The official camera: facing the robot across the table, framed on the workspace.

It looks along +y (away from the viewer, "behind") and down at 55 degrees, from the
middle of the near side of the table, so image-left is world -x. The framing was fitted
(``tests/world/test_camera_framing.py`` checks it) so that the whole target area,
object centres x in [-0.36, 0.36], y in [-0.22, 0.22], widened by the largest object's
half diagonal (0.045 m) and raised to a 3-high stack (0.155 m), lies inside the image
with a margin of about 6 px at 320x240: the near corners bound the left, right and
bottom edges. The band above the workspace shows the far strip of the table and the
base of the Franka Panda standing at (0, 0.5) on the far edge; nothing of the robot
can hide an object (the robot stays at y >= 0.3, behind every object).
"""

from __future__ import annotations

import math

from nsrmp_bench.geometry.camera import Camera

__all__ = ["OFFICIAL_CAMERA", "official_camera"]

OFFICIAL_CAMERA = Camera(
    width=320,
    height=240,
    fov_y_deg=40.0,
    eye=(0.0, -0.555, 1.636),
    target=(0.0, 0.153, 0.625),
    near=0.05,
    far=4.0,
)
"""320x240 RGB; image-left is world -x and "behind" (+y) is away from the camera."""


def official_camera(width: int = 320, height: int = 240) -> Camera:
    """The official camera at the given image size, same pose.

    At 4:3 or wider the vertical field of view is kept (1024x768 is the same picture as
    320x240). Narrower images (e.g. 256x256) keep the *horizontal* field of view instead,
    so that the workspace still fits from side to side, with more room above and below.
    """
    cam = OFFICIAL_CAMERA.resized(width, height)
    official_aspect = OFFICIAL_CAMERA.width / OFFICIAL_CAMERA.height
    if width / height >= official_aspect:
        return cam
    half_x = math.atan(math.tan(math.radians(OFFICIAL_CAMERA.fov_y_deg) / 2.0) * official_aspect)
    fov_y = 2.0 * math.degrees(math.atan(math.tan(half_x) * height / width))
    return Camera(width, height, fov_y, cam.eye, cam.target, cam.up, cam.near, cam.far)
