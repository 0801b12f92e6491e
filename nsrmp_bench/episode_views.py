"""What an episode looks like from its camera: its gold boxes, positions and initial scene.

A rendered episode carries its camera and its targets (boxes and poses per rendered
state). A symbolic-only episode is seen through the official camera, and its boxes are the
projection of its symbolic states (:func:`nsrmp_bench.geometry.projection.states_boxes`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.episode import Episode
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.geometry.default_camera import OFFICIAL_CAMERA
from nsrmp_bench.geometry.projection import states_boxes
from nsrmp_bench.scene import Pose, Scene

__all__ = ["episode_boxes", "episode_camera", "episode_initial_state", "episode_positions"]


def episode_camera(episode: Episode) -> Camera:
    """The episode's camera: its rendering's, or the official one when symbolic-only."""
    return OFFICIAL_CAMERA if episode.rendering is None else episode.rendering.camera


def episode_boxes(episode: Episode) -> NDArray[np.float64]:
    """Gold amodal boxes ``(S+1, N, 4)``: rendered targets, or projected symbolic states."""
    if episode.rendering is not None:
        return np.asarray(episode.rendering.targets.boxes_amodal, dtype=np.float64)
    sym = episode.symbolic
    return states_boxes(OFFICIAL_CAMERA, sym.scene.objects, sym.states)


def episode_positions(episode: Episode) -> NDArray[np.float64]:
    """Gold object centres ``(S+1, N, 3)`` in metres (world frame)."""
    if episode.rendering is not None:
        return np.asarray(episode.rendering.targets.poses, dtype=np.float64)[..., :3]
    states = episode.symbolic.states
    return np.array([[p.position for p in s] for s in states], dtype=np.float64)


def episode_initial_state(episode: Episode) -> Scene:
    """The scene as it starts: rendered initial poses when rendered, else symbolic."""
    sym = episode.symbolic
    if episode.rendering is None:
        return sym.scene
    poses = np.asarray(episode.rendering.targets.poses, dtype=np.float64)[0]
    initial = tuple(
        Pose(
            (float(p[0]), float(p[1]), float(p[2])),
            (float(p[3]), float(p[4]), float(p[5]), float(p[6])),
        )
        for p in poses
    )
    return sym.scene.at(initial)
