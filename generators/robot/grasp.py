"""Grasp geometry of the Panda's parallel gripper: where to hold an object, how to turn
the hand so that neither the fingers nor the hand touch a neighbour, how high to carry it.

Pure geometry on object footprints (numpy only). The gripper points straight down; at
gripper yaw ``theta`` (the hand's orientation is Euler ``(pi, 0, theta)``) the fingers
close along ``(sin theta, -cos theta)``. An object with yaw ``psi`` is held across two
opposite faces, so ``theta = psi (mod pi/2)``; of the two ways to hold it the planner takes
the one with room around the fingers and hand at the pick and the place spot.

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
    "release_lift",
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
_TIGHT_MARGIN: Final = 0.004  # the same where neighbours leave no room for the first
_GRIP_FRACTION: Final = 0.5  # hold the body at this fraction of its height
_MIN_ROOM: Final = 0.002  # m between the open gripper and a neighbour when releasing
_DROP_STEP: Final = 0.005  # m
_MAX_DROP: Final = 0.05  # m
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


def finger_opening(obj: SceneObject, tight: bool = False) -> float:
    """Opening of one finger (m) that clears ``obj``'s faces by a margin (a smaller one if
    ``tight``: for crowded spots), capped at the max."""
    half = max(obj.extents[0], obj.extents[1]) / 2.0
    margin = _TIGHT_MARGIN if tight else _OPEN_MARGIN
    return min(MAX_FINGER_OPENING, half + _FINGER_INNER_OFFSET + margin)


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


def _overlap(a: F64, b: F64) -> float:
    """Smallest overlap of convex polygons ``a`` and ``b`` over the separating-axis
    candidates (their edge normals); <= 0 when some axis separates them."""
    least = math.inf
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        normals = np.stack([-edges[:, 1], edges[:, 0]], axis=1)
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        pa = a @ normals.T
        pb = b @ normals.T
        overlap = np.minimum(pa.max(axis=0), pb.max(axis=0)) - np.maximum(pa.min(axis=0),
                                                                            pb.min(axis=0))
        least = min(least, float(overlap.min()))
    return least


def _point_segment(p: F64, a: F64, b: F64) -> F64:
    """Distances of points ``p`` (n, 2) to segments ``a``-``b`` (m, 2): (n, m)."""
    ab = b - a
    ap = p[:, None, :] - a[None, :, :]
    t = np.clip((ap * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-18), 0.0, 1.0)
    closest = a[None, :, :] + t[..., None] * ab[None, :, :]
    out: F64 = np.linalg.norm(p[:, None, :] - closest, axis=-1)
    return out


def _polygon_distance(a: F64, b: F64) -> float:
    """Signed distance between convex polygons: the gap, or minus the depth they overlap."""
    depth = _overlap(a, b)
    if depth > 0.0:
        return -depth
    ea, eb = np.roll(a, -1, axis=0), np.roll(b, -1, axis=0)
    return float(min(_point_segment(a, b, eb).min(), _point_segment(b, a, ea).min()))


def clearance(parts: Sequence[tuple[F64, float, float]], obs: Sequence[Obstacle],
              z_margin: float = 0.003) -> float:
    """Smallest horizontal gap between a gripper part and an obstacle at an overlapping
    height, negative when they overlap (by that depth); ``inf`` when nothing is at the
    parts' heights."""
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
    """Gripper yaws at pick and place, the finger opening and the room left at both ends."""

    pick_yaw: float
    place_yaw: float
    opening: float
    clearance_pick: float
    clearance_place: float


_SAFE_ROOM: Final = 0.01  # m of room that is enough; beyond it, prefer the neutral yaw


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
    """Of the two ways to hold the object (across either pair of faces), the one with room
    for the fingers and hand at the pick, then at the place, then nearer the neutral yaw.

    Room at the pick comes first because nothing else can make it; at the place the hand
    can instead open higher (:func:`release_lift`). The object turns with the hand by
    exactly its yaw change, so it keeps its target orientation.
    """
    turn = wrap_angle(place.yaw - pick.yaw)
    z_pick = grasp_height(obj, pick)
    n_pick = neutral_yaw(pick.position[0], pick.position[1], base)
    n_place = neutral_yaw(place.position[0], place.position[1], base)
    best: tuple[tuple[float, float, bool, float], GraspPlan] | None = None
    for k, tight in ((0, False), (1, False), (0, True), (1, True)):  # two closing axes
        opening = finger_opening(obj, tight)
        theta = _nearest_mod(pick.yaw + k * math.pi / 2.0, math.pi, n_pick)
        # theta and theta + pi close along the same axis: keep the one nearer both neutrals
        theta = min((theta, theta + math.pi, theta - math.pi),
                    key=lambda t: abs(wrap_angle(t - n_pick)) + abs(wrap_angle(t + turn - n_place)))
        theta = n_pick + wrap_angle(theta - n_pick)
        place_theta = theta + turn
        c_pick = clearance(gripper_parts(pick.position[:2], theta, z_pick, opening),
                           others_at_pick)
        c_place = clearance(gripper_parts(place.position[:2], place_theta, place_grasp_z,
                                          opening), others_at_place)
        deviation = abs(theta - n_pick) + abs(place_theta - n_place)
        key = (min(c_pick, _SAFE_ROOM), min(c_place, _SAFE_ROOM), not tight, -deviation)
        if best is None or key > best[0]:
            best = (key, GraspPlan(theta, place_theta, opening, c_pick, c_place))
    assert best is not None
    return best[1]


def release_lift(place: Vec, place_yaw: float, z_grasp: float, opening: float,
                 others: Sequence[Obstacle], room: float = _MIN_ROOM,
                 most: float = _MAX_DROP) -> float:
    """How much higher (m) than the resting height the hand must open so that no part of
    the gripper touches a neighbour: 0 when there is room; the object then drops that far.
    ``most`` bounds it (when even that is not enough, the hand opens at ``most``)."""
    lift = 0.0
    while lift < most:
        if clearance(gripper_parts(place[:2], place_yaw, z_grasp + lift, opening),
                     others) >= room:
            return lift
        lift = round(lift + _DROP_STEP, 6)
    return most


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
