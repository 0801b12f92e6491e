"""Grasp geometry of the Panda's parallel gripper: where to hold an object, how to turn
the hand so that neither the fingers nor the hand touch a neighbour, how high to carry it.

Pure geometry on object footprints (numpy only). The gripper points straight down; at
gripper yaw ``theta`` (the hand's orientation is Euler ``(pi, 0, theta)``) the fingers
close along ``(sin theta, -cos theta)``. An object with yaw ``psi`` is held across two
opposite faces, so ``theta = psi (mod pi/2)``; of the candidate yaws the planner takes the
one with the most room around the fingers and hand at both the pick and the place spot.

The gripper's dimensions below were measured from pybullet_data's Panda collision
meshes (link AABBs in the grasp-target frame).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.generators.world.assets import LEGO_STUD_HEIGHT
from nsrmp_bench.scene import Pose, SceneObject
from nsrmp_bench.vocabulary import TABLE_TOP_Z

__all__ = [
    "FINGER_BELOW_GRASP",
    "MAX_FINGER_OPENING",
    "GraspPlan",
    "Obstacle",
    "body_height",
    "choose_grasp_yaw",
    "clearance",
    "finger_opening",
    "grasp_height",
    "gripper_parts",
    "neutral_yaw",
    "obstacles",
    "travel_height",
    "wrap_angle",
]

F64 = NDArray[np.float64]
Vec = Sequence[float] | NDArray[np.float64]

MAX_FINGER_OPENING: Final = 0.04
"""Largest opening of one finger (m); the hand opens to twice this."""
FINGER_BELOW_GRASP: Final = 0.0112
"""The fingertips reach this far below the grasp target (m)."""
_FINGER_INNER_OFFSET: Final = 0.0041  # inner pad face sits this far inside the opening
_FINGER_THICKNESS: Final = 0.0345  # along the closing axis
_FINGER_HALF_WIDTH: Final = 0.0145  # across the closing axis
_FINGER_TOP: Final = 0.0505  # top of the finger above the grasp target
_HAND_HALF: Final = (0.0356, 0.108)  # (across, along) the closing axis
_HAND_BOTTOM: Final = 0.035  # above the grasp target
_HAND_TOP: Final = 0.135
_OPEN_MARGIN: Final = 0.008  # free room between pad and object face when open (per side)
_GRIP_FRACTION: Final = 0.5  # hold the body at this fraction of its height
_NEUTRAL_OFFSET: Final = 0.7  # rad: gripper yaw minus base direction at mid-range joint 7


def wrap_angle(a: float) -> float:
    """``a`` wrapped into ``(-pi, pi]``."""
    return math.atan2(math.sin(a), math.cos(a))


def body_height(obj: SceneObject) -> float:
    """Height of the part that the fingers hold (a lego brick's body, without studs)."""
    ez = obj.extents[2]
    return ez - LEGO_STUD_HEIGHT if obj.shape == "lego" else ez


def grasp_height(obj: SceneObject, pose: Pose) -> float:
    """World z of the grasp target when holding ``obj`` resting at ``pose``."""
    bottom = pose.position[2] - obj.extents[2] / 2.0
    return bottom + _GRIP_FRACTION * body_height(obj)


def finger_opening(obj: SceneObject) -> float:
    """Opening of one finger (m) that clears ``obj``'s faces by a margin, capped at the max."""
    half = max(obj.extents[0], obj.extents[1]) / 2.0
    return min(MAX_FINGER_OPENING, half + _FINGER_INNER_OFFSET + _OPEN_MARGIN)


@dataclass(frozen=True)
class Obstacle:
    """An object the gripper must avoid: its footprint corners (4, 2) and z range."""

    index: int
    corners: F64
    bottom: float
    top: float

    @property
    def radius(self) -> float:
        """Radius of the footprint's circumscribed circle about its centre."""
        c = self.corners.mean(axis=0)
        return float(np.max(np.linalg.norm(self.corners - c, axis=1)))

    @property
    def centre(self) -> F64:
        """Footprint centre (x, y)."""
        out: F64 = self.corners.mean(axis=0)
        return out


def _rectangle(centre: Vec, half_along: float, half_across: float,
               along: F64) -> F64:
    """Corners (4, 2) of a rectangle with half sizes along/across the unit vector ``along``."""
    across = np.array([-along[1], along[0]])
    c = np.asarray(centre, dtype=np.float64)
    return np.array([
        c + sa * half_along * along + sc * half_across * across
        for sa, sc in ((1, 1), (1, -1), (-1, -1), (-1, 1))
    ])


def obstacles(objects: Sequence[SceneObject], poses: Sequence[Pose],
              exclude: Sequence[int] = ()) -> list[Obstacle]:
    """Footprints and heights of every object except ``exclude``, at ``poses`` (yaw only)."""
    out: list[Obstacle] = []
    skip = set(exclude)
    for i, (obj, pose) in enumerate(zip(objects, poses, strict=True)):
        if i in skip:
            continue
        yaw = pose.yaw
        along = np.array([math.cos(yaw), math.sin(yaw)])
        ex, ey, ez = obj.extents
        corners = _rectangle(pose.position[:2], ex / 2.0, ey / 2.0, along)
        z = pose.position[2]
        out.append(Obstacle(i, corners, z - ez / 2.0, z + ez / 2.0))
    return out


def gripper_parts(centre: Vec, theta: float, z_grasp: float,
                  opening: float) -> list[tuple[F64, float, float]]:
    """The fingers' and hand's footprints (4, 2) with their z ranges, for a gripper whose
    grasp target is at ``(centre, z_grasp)`` with yaw ``theta`` and finger ``opening``."""
    axis = np.array([math.sin(theta), -math.cos(theta)])
    c = np.asarray(centre, dtype=np.float64)
    parts: list[tuple[F64, float, float]] = []
    mid = opening - _FINGER_INNER_OFFSET + _FINGER_THICKNESS / 2.0
    for sign in (1.0, -1.0):
        finger = _rectangle(c + sign * mid * axis, _FINGER_THICKNESS / 2.0, _FINGER_HALF_WIDTH,
                            axis)
        parts.append((finger, z_grasp - FINGER_BELOW_GRASP, z_grasp + _FINGER_TOP))
    hand = _rectangle(c, _HAND_HALF[1], _HAND_HALF[0], axis)
    parts.append((hand, z_grasp + _HAND_BOTTOM, z_grasp + _HAND_TOP))
    return parts


def _separated(a: F64, b: F64) -> bool:
    """Whether convex polygons ``a`` and ``b`` are separated (separating axis test)."""
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        normals = np.stack([-edges[:, 1], edges[:, 0]], axis=1)
        pa = a @ normals.T
        pb = b @ normals.T
        if np.any((pa.max(axis=0) < pb.min(axis=0)) | (pb.max(axis=0) < pa.min(axis=0))):
            return True
    return False


def _point_segment(p: F64, a: F64, b: F64) -> F64:
    """Distances of points ``p`` (n, 2) to segments ``a``-``b`` (m, 2): (n, m)."""
    ab = b - a
    ap = p[:, None, :] - a[None, :, :]
    t = np.clip((ap * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-18), 0.0, 1.0)
    closest = a[None, :, :] + t[..., None] * ab[None, :, :]
    out: F64 = np.linalg.norm(p[:, None, :] - closest, axis=-1)
    return out


def _polygon_distance(a: F64, b: F64) -> float:
    """Distance between convex polygons; 0 when they overlap."""
    if not _separated(a, b):
        return 0.0
    ea, eb = np.roll(a, -1, axis=0), np.roll(b, -1, axis=0)
    return float(min(_point_segment(a, b, eb).min(), _point_segment(b, a, ea).min()))


def clearance(parts: Sequence[tuple[F64, float, float]], obs: Sequence[Obstacle],
              z_margin: float = 0.003) -> float:
    """Smallest horizontal gap between a gripper part and an obstacle at an overlapping
    height (``inf`` when nothing is at the parts' heights)."""
    best = math.inf
    for poly, zlo, zhi in parts:
        for o in obs:
            if o.top + z_margin <= zlo or o.bottom - z_margin >= zhi:
                continue
            if float(np.linalg.norm(poly.mean(axis=0) - o.centre)) > 0.25:
                continue
            best = min(best, _polygon_distance(poly, o.corners))
    return best


def neutral_yaw(x: float, y: float, base: Vec) -> float:
    """The gripper yaw at which the Panda's last joint is near the middle of its range when
    reaching down at ``(x, y)`` (measured: the direction from the base, plus 0.7 rad)."""
    return wrap_angle(math.atan2(y - base[1], x - base[0]) + _NEUTRAL_OFFSET)


@dataclass(frozen=True)
class GraspPlan:
    """Gripper yaws at pick and place, the finger opening, the room left at both ends and
    the quarter turns the object makes beyond its target yaw (0 unless that was the only
    way to find room; every footprint here is square, so its box does not change)."""

    pick_yaw: float
    place_yaw: float
    opening: float
    clearance_pick: float
    clearance_place: float
    quarter_turns: int = 0


_SAFE_ROOM: Final = 0.01  # m of room that is enough: prefer the exact yaw among these
_ENOUGH_ROOM: Final = 0.05  # m beyond which more room does not matter
_MAX_DEVIATION: Final = 2.2  # rad from the neutral yaw (the last joint's range is +-2.97)


def _nearest_mod(angle: float, period: float, near: float) -> float:
    """The angle congruent to ``angle`` modulo ``period`` closest to ``near``."""
    k = round((near - angle) / period)
    return angle + k * period


def choose_grasp_yaw(
    obj: SceneObject,
    pick: Pose,
    place: Pose,
    others_at_pick: Sequence[Obstacle],
    others_at_place: Sequence[Obstacle],
    base: Vec,
    place_grasp_z: float,
) -> GraspPlan:
    """The grasp with enough room at both ends, preferring the exact target yaw, then more
    room, then yaws near the neutral one.

    The hand holds the object across one of two face pairs (two closing axes); the object
    turns with the hand, so the place yaw is the pick yaw plus the object's yaw change,
    plus a number of quarter turns when only a turned object leaves the fingers room.
    """
    opening = finger_opening(obj)
    turn = _nearest_mod(wrap_angle(place.yaw - pick.yaw), math.pi / 2.0, 0.0)
    z_pick = grasp_height(obj, pick)
    n_pick = neutral_yaw(pick.position[0], pick.position[1], base)
    n_place = neutral_yaw(place.position[0], place.position[1], base)
    best: tuple[tuple[float, bool, float, float], GraspPlan] | None = None
    for k in range(2):  # the two closing axes at the pick
        theta = _nearest_mod(pick.yaw + k * math.pi / 2.0, math.pi, n_pick)
        c_pick = clearance(gripper_parts(pick.position[:2], theta, z_pick, opening),
                           others_at_pick)
        for m in (0, 1, -1, 2, -2):
            place_theta = theta + turn + m * math.pi / 2.0
            deviation = abs(place_theta - n_place)
            if deviation > _MAX_DEVIATION and m != 0:
                continue
            c_place = clearance(gripper_parts(place.position[:2], place_theta, place_grasp_z,
                                              opening), others_at_place)
            room = min(c_pick, c_place)
            key = (min(room, _SAFE_ROOM), m == 0, min(room, _ENOUGH_ROOM),
                   -(abs(theta - n_pick) + deviation))
            plan = GraspPlan(theta, place_theta, opening, c_pick, c_place, m)
            if best is None or key > best[0]:
                best = (key, plan)
    assert best is not None
    return best[1]


def travel_height(
    start: Vec,
    end: Vec,
    obs: Sequence[Obstacle],
    hang: float,
    clearance_m: float,
    corridor: float = 0.12,
) -> float:
    """Lowest grasp-target z from which a held object hanging ``hang`` m below it clears
    every obstacle near the straight path from ``start`` to ``end`` (x, y) by
    ``clearance_m``; the table counts as an obstacle everywhere."""
    a = np.asarray(start[:2], dtype=np.float64)
    b = np.asarray(end[:2], dtype=np.float64)
    top = TABLE_TOP_Z
    for o in obs:
        d = float(_point_segment(o.centre[None, :], a[None, :], b[None, :])[0, 0])
        if d <= corridor + o.radius:
            top = max(top, o.top)
    return top + clearance_m + hang
