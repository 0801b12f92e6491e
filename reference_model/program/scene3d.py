"""Objects in 3D from the inputs alone, and the analytic action rule that moves them.

Each object's state comes from its initial box, the depth image and the camera: its box
centre is back-projected through the camera at the depth of its visible surface plus
``rule.centre`` times its estimated size (the centre lies behind the visible surface: v1
back-projected at the surface and put every position 2.5 cm short, D8), and its size is
the box width at that depth. An action places the mover in 3D beside or on its base and
projects the result back into the image (D7): ``top`` lifts it above the base's centre,
``left``/``right`` set it beside the base along world -x/+x (image-left is -x) at its
resting height, each by its own weighted sum of the two objects' sizes and heights and a
constant (:data:`FEATURES`). The new box keeps the mover's box size, scaled by the ratio
of its old and new camera depths.

The weights are the rule's learned corrections, fitted on training episodes by
:func:`~.consistent.fit_rule` (least squares on where the final boxes put the movers).
Everything is numpy and vectorised over candidate programs.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.geometry.camera import Camera

__all__ = ["FEATURES", "LEFT", "RIGHT", "TOP", "ActionRule", "SceneState", "move",
           "project_boxes", "rule_features", "scene_state"]

F64 = NDArray[np.float64]
TOP, LEFT, RIGHT = 0, 1, 2  # indices into nsrmp_bench.vocabulary.ACTIONS


FEATURES = ("mover size", "base size", "mover height", "base height", "1")
"""What the action rule's lift and side distance are weighted sums of."""


@dataclass(frozen=True)
class ActionRule:
    """The fitted coefficients of the action rule (see the module doc): ``top`` weighs
    :data:`FEATURES` into the lift above the base's centre, ``side`` into the distance
    beside it along world x."""

    centre: float = 0.3
    top: tuple[float, ...] = (0.375, 0.375, 0.0, 0.0, 0.0)
    side: tuple[float, ...] = (0.75, 0.75, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if len(self.top) != len(FEATURES) or len(self.side) != len(FEATURES):
            msg = (f"an action rule has {len(FEATURES)} top and {len(FEATURES)} side "
                   f"coefficients, not {len(self.top)} and {len(self.side)}")
            raise ValueError(msg)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (stored in checkpoints)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ActionRule:
        """Inverse of :meth:`to_dict`."""
        return cls(float(data["centre"]), tuple(float(v) for v in data["top"]),
                   tuple(float(v) for v in data["side"]))

    def values(self) -> list[float]:
        """(centre, *top, *side): the form a checkpoint's buffer holds."""
        return [self.centre, *self.top, *self.side]

    @classmethod
    def from_values(cls, values: list[float]) -> ActionRule:
        """Inverse of :meth:`values`; three values are the first design's (centre, lift,
        gap), a lift and a gap times the two objects' mean size."""
        v = [float(x) for x in values]
        if len(v) == 3:
            centre, lift, gap = v
            return cls(centre, (lift / 2, lift / 2, 0.0, 0.0, 0.0),
                       (gap / 2, gap / 2, 0.0, 0.0, 0.0))
        t = 1 + len(FEATURES)
        return cls(v[0], tuple(v[1:t]), tuple(v[t:]))


@dataclass(frozen=True)
class SceneState:
    """One episode's objects: centres (N, 3) world metres, sizes and heights (N,) metres
    (the box's width and height at the visible surface's depth), box sizes (N, 2) pixels
    and camera depths (N,) of the initial state, and the camera."""

    centres: F64
    sizes: F64
    heights: F64
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
    height = wh[:, 1] * d / camera.focal
    depth = d + rule.centre * size
    uv = np.stack([(b[:, 0] + b[:, 2]) / 2, (b[:, 1] + b[:, 3]) / 2], axis=1)
    return SceneState(camera.backproject(uv, depth), size, height, wh, depth, camera)


def rule_features(state: SceneState, subject: NDArray[Any], base: NDArray[Any]) -> F64:
    """(K, len(FEATURES)) the action rule's features of K (subject, base) pairs."""
    return np.stack([state.sizes[subject], state.sizes[base], state.heights[subject],
                     state.heights[base], np.ones(len(subject))], axis=1)


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
    new = base_c.copy()
    top = a == TOP
    lift = rule_features(state, s[top], bs[top]) @ np.asarray(rule.top)
    gap = rule_features(state, s[~top], bs[~top]) @ np.asarray(rule.side)
    new[top, 2] = base_c[top, 2] + lift
    side = np.where(a == LEFT, -1.0, 1.0)
    new[~top, 0] = base_c[~top, 0] + side[~top] * gap
    new[~top, 2] = state.centres[s[~top], 2]  # back at its resting height
    out[k, s] = new
    return out


def project_boxes(state: SceneState, centres: F64) -> F64:
    """Boxes (..., N, 4) pixel xyxy of the objects at ``centres`` (..., N, 3)."""
    uv, z = state.camera.project(centres)
    scale = state.depths / np.maximum(z, 1e-6)
    half = state.box_wh * scale[..., None] / 2
    return np.concatenate([uv - half, uv + half], axis=-1)
