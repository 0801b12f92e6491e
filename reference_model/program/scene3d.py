"""Objects in 3D from the inputs alone, and the analytic action rule that moves them.

Each object's state comes from its initial box, the depth image and the camera: its box
centre is back-projected through the camera at the depth of its visible surface plus
``rule.centre`` times its estimated size (the centre lies behind the visible surface: v1
back-projected at the surface and put every position 2.5 cm short, D8), and its size is
the box width at that depth. An action places the mover in 3D beside or on its base and
projects the result back into the image (D7): ``top`` lifts it by ``rule.lift`` times the
two objects' mean size above the base's centre; ``left``/``right`` set it ``rule.gap``
times that mean size along world -x/+x (image-left is -x) at its resting height. The new
box keeps the mover's box size, scaled by the ratio of its old and new camera depths.

The three scalars are the rule's learned corrections, fitted on training episodes by
:func:`fit_rule`. Everything is numpy and vectorised over candidate programs.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.geometry.camera import Camera

__all__ = ["ActionRule", "SceneState", "move", "project_boxes", "scene_state"]

F64 = NDArray[np.float64]
TOP, LEFT, RIGHT = 0, 1, 2  # indices into nsrmp_bench.vocabulary.ACTIONS


@dataclass(frozen=True)
class ActionRule:
    """The fitted scalars of the action rule (see the module doc)."""

    centre: float = 0.3
    lift: float = 0.75
    gap: float = 1.5

    def to_dict(self) -> dict[str, float]:
        """JSON-able form (stored in checkpoints)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ActionRule:
        """Inverse of :meth:`to_dict`."""
        return cls(**{k: float(v) for k, v in data.items()})

    def values(self) -> list[float]:
        """(centre, lift, gap): the form a checkpoint's buffer holds."""
        return [self.centre, self.lift, self.gap]

    @classmethod
    def from_values(cls, values: list[float]) -> ActionRule:
        """Inverse of :meth:`values`."""
        centre, lift, gap = (float(v) for v in values)
        return cls(centre, lift, gap)


@dataclass(frozen=True)
class SceneState:
    """One episode's objects: centres (N, 3) world metres, sizes (N,) metres, box sizes
    (N, 2) pixels and camera depths (N,) of the initial state, and the camera."""

    centres: F64
    sizes: F64
    box_wh: F64
    depths: F64
    camera: Camera

    def __len__(self) -> int:
        return len(self.sizes)


def scene_state(boxes: NDArray[Any], surface_depth: NDArray[Any], camera: Camera,
                rule: ActionRule) -> SceneState:
    """The 3D state of an episode's objects from their initial boxes (N, 4) and the depth
    of each one's visible surface (N,)."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    d = np.asarray(surface_depth, dtype=np.float64).reshape(-1)
    wh = np.stack([b[:, 2] - b[:, 0], b[:, 3] - b[:, 1]], axis=1)
    size = wh[:, 0] * d / camera.focal
    depth = d + rule.centre * size
    uv = np.stack([(b[:, 0] + b[:, 2]) / 2, (b[:, 1] + b[:, 3]) / 2], axis=1)
    return SceneState(camera.backproject(uv, depth), size, wh, depth, camera)


def move(state: SceneState, centres: F64, subject: NDArray[Any], base: NDArray[Any],
         action: NDArray[Any], rule: ActionRule) -> F64:
    """Centres (K, N, 3) after moving ``subject[k]`` by ``action[k]`` relative to
    ``base[k]`` in world ``centres[k]`` (K candidate programs, one step each)."""
    k = np.arange(len(subject))
    s = np.asarray(subject)
    bs = np.asarray(base)
    a = np.asarray(action)
    out = centres.copy()
    base_c = centres[k, bs]
    mean = (state.sizes[s] + state.sizes[bs]) / 2
    new = base_c.copy()
    top = a == TOP
    new[top, 2] = base_c[top, 2] + rule.lift * mean[top]
    side = np.where(a == LEFT, -1.0, 1.0)
    new[~top, 0] = base_c[~top, 0] + side[~top] * rule.gap * mean[~top]
    new[~top, 2] = state.centres[s[~top], 2]  # back at its resting height
    out[k, s] = new
    return out


def project_boxes(state: SceneState, centres: F64) -> F64:
    """Boxes (..., N, 4) pixel xyxy of the objects at ``centres`` (..., N, 3)."""
    uv, z = state.camera.project(centres)
    scale = state.depths / np.maximum(z, 1e-6)
    half = state.box_wh * scale[..., None] / 2
    return np.concatenate([uv - half, uv + half], axis=-1)
