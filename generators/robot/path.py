"""Drawing a recorded robot trajectory over an image: the end effector's path.

:func:`ee_path_pixels` projects the grasp target's recorded positions through a camera;
:func:`draw_ee_path` draws them on an RGB image as a polyline, one colour per program
step, with a filled dot where the hand closed (grasp) and a ring where it opened
(release). Meant for ``show`` (on the initial image, or a step's panel with ``step=k``).
"""

from __future__ import annotations

from types import ModuleType
from typing import Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require
from nsrmp_bench.episode import Trajectory
from nsrmp_bench.geometry.camera import Camera

__all__ = ["STEP_COLOURS", "draw_ee_path", "ee_path_pixels", "gripper_events"]

STEP_COLOURS: Final[tuple[tuple[int, int, int], ...]] = (
    (255, 140, 0), (0, 160, 255), (220, 0, 160), (0, 200, 90), (255, 215, 0),
    (120, 80, 255), (255, 60, 60),
)
"""RGB colour of step k's path: ``STEP_COLOURS[k % 7]``."""

_STILL: Final = 0.05  # m/s: the hand stands still below this speed
_FINGER_MOVE: Final = 0.002  # m of opening change between samples: the fingers move


def ee_path_pixels(camera: Camera, trajectory: Trajectory,
                   step: int | None = None) -> NDArray[np.float64]:
    """Pixel positions ``(T, 2)`` of the recorded grasp-target positions (of ``step``)."""
    pos = np.asarray(trajectory.ee_pose, dtype=np.float64)[:, :3]
    if step is not None:
        pos = pos[np.asarray(trajectory.step) == step]
    uv, _ = camera.project(pos)
    out: NDArray[np.float64] = uv.reshape(-1, 2)
    return out


def gripper_events(trajectory: Trajectory) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Per program step, the sample where the hand started to close on the object (grasp)
    and to open (release): the fingers moving while the hand stands still, lowest of such
    moments. (The fingers also move while the arm travels to and from rest.)"""
    grip = np.asarray(trajectory.gripper, dtype=np.float64)
    if len(grip) < 2:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty
    dt = np.maximum(np.diff(np.asarray(trajectory.time, dtype=np.float64)), 1e-9)
    speed = np.linalg.norm(np.diff(np.asarray(trajectory.ee_pose)[:, :3], axis=0), axis=1) / dt
    still = speed < _STILL
    closing = (np.diff(grip) < -_FINGER_MOVE) & still
    opening = (np.diff(grip) > _FINGER_MOVE) & still

    z = np.asarray(trajectory.ee_pose)[:, 2]
    steps = np.asarray(trajectory.step)

    def lowest_start_per_step(mask: NDArray[np.bool_]) -> NDArray[np.int64]:
        first = np.flatnonzero(mask & ~np.concatenate([[False], mask[:-1]]))
        picked = [int(first[steps[first] == k][np.argmin(z[first[steps[first] == k]])])
                  for k in np.unique(steps[first])]
        return np.asarray(picked, dtype=np.int64)

    return lowest_start_per_step(closing), lowest_start_per_step(opening)


def draw_ee_path(rgb: NDArray[np.uint8], camera: Camera, trajectory: Trajectory, *,
                 step: int | None = None, scale: int = 1,
                 thickness: int = 1) -> NDArray[np.uint8]:
    """A copy of ``rgb`` (an image of ``camera``, enlarged ``scale`` times) with the path."""
    cv2: ModuleType = require("cv2")
    out = np.ascontiguousarray(rgb.copy())
    if len(trajectory.time) == 0:
        return out
    steps = np.asarray(trajectory.step)
    uv_all = ee_path_pixels(camera, trajectory) * scale
    closes, opens = gripper_events(trajectory)
    for k in sorted({int(v) for v in np.unique(steps)}):
        if step is not None and k != step:
            continue
        colour = STEP_COLOURS[k % len(STEP_COLOURS)]
        pts = np.round(uv_all[steps == k]).astype(np.int32).reshape(-1, 1, 2)
        if len(pts) > 1:
            cv2.polylines(out, [pts], False, colour, thickness * scale, cv2.LINE_AA)
        for i in closes[steps[closes] == k]:
            centre = tuple(int(v) for v in np.round(uv_all[i]))
            cv2.circle(out, centre, 3 * scale, colour, -1, cv2.LINE_AA)
        for i in opens[steps[opens] == k]:
            centre = tuple(int(v) for v in np.round(uv_all[i]))
            cv2.circle(out, centre, 3 * scale, colour, thickness * scale, cv2.LINE_AA)
    return out
