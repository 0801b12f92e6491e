"""From a prediction to robot targets: which objects to move, in what order, to where.

A prediction says where objects end up in one of three ways, used in this order of
preference (``source="auto"``):

* ``program``: grounded steps. They are checked by the symbolic executor from the initial
  scene; a step it refuses (covered subject, occupied target, ...) is not attempted by the
  robot either. At execution each step's target is the action geometry on the physical
  state before it.
* ``positions``: predicted final object centres (m). An object whose predicted centre is
  more than :data:`MOVE_THRESHOLD` from its initial one is moved there; its support (the
  table or the object under it) is the one whose top face is nearest its predicted bottom.
* ``boxes``: predicted final amodal boxes (px). Each box is back-projected through the
  known camera: for every support (the table, or the top face of an object), the centre on
  that plane whose projected 3D box has the predicted box's centre is found by a few
  fixed-point steps of ray-plane intersection; the support whose projected box overlaps
  the prediction best (and where the object fits) is kept. No learned mapping.

Moves are ordered so that an object is moved before one that will rest on it, and an
object resting on another before that other one. Pure geometry: no PyBullet here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.dsl.actions import apply_step, footprint_half, rests_on
from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.errors import InfeasibleStep, InvalidArgument
from nsrmp_bench.geometry.boxes import box_iou
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.scene import Pose, SceneObject, State
from nsrmp_bench.vocabulary import TABLE_TOP_Z

__all__ = [
    "MOVE_THRESHOLD",
    "SOURCES",
    "PlannedMove",
    "ReplayPlan",
    "box_of",
    "fit_box_on_plane",
    "order_moves",
    "plan_from_boxes",
    "plan_from_positions",
    "plan_from_program",
]

F64 = NDArray[np.float64]
Vec = Sequence[float] | NDArray[np.float64]

SOURCES: Final = ("auto", "program", "positions", "boxes")
"""What a replay may take its targets from (``auto``: the first one the prediction has)."""

MOVE_THRESHOLD: Final = 0.01
"""An object whose predicted centre is this far (m) from its initial one is moved."""
_FIT_ITERATIONS: Final = 6
_SUPPORT_Z_TOL: Final = 0.015  # m between a predicted bottom and a support's top
_OVERLAP_TOL: Final = 0.005  # m of footprint overlap tolerated on the table hypothesis


@dataclass(frozen=True)
class PlannedMove:
    """Move ``subject`` so its centre lands at ``xy`` on ``support`` (-1: the table).

    ``support_xy`` is where the support was planned to be; at execution the target shifts
    with the support's real position. ``step`` is set for program replays (the target is
    then the action geometry on the physical state).
    """

    subject: int
    xy: tuple[float, float]
    support: int
    support_xy: tuple[float, float] | None = None
    step: GroundedStep | None = None


@dataclass(frozen=True)
class ReplayPlan:
    """The moves to make and what was left out (with the reason)."""

    source: str
    moves: tuple[PlannedMove, ...]
    refused: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able summary."""
        return {
            "source": self.source,
            "moves": [
                {"subject": m.subject, "xy": list(m.xy), "support": m.support,
                 "step": None if m.step is None else m.step.to_list()}
                for m in self.moves
            ],
            "refused": list(self.refused),
        }


# -- programs --------------------------------------------------------------------------
def plan_from_program(objects: Sequence[SceneObject], initial: State,
                      steps: Sequence[GroundedStep]) -> ReplayPlan:
    """The steps the symbolic executor accepts, in order, from ``initial``."""
    state = initial
    moves: list[PlannedMove] = []
    refused: list[str] = []
    for k, step in enumerate(steps):
        n = len(objects)
        if not (0 <= step.subject < n and 0 <= step.reference < n):
            refused.append(f"step {k + 1} {step.to_list()}: object index out of range 0..{n - 1}")
            continue
        try:
            after = apply_step(objects, state, step)
        except InfeasibleStep as exc:
            refused.append(f"step {k + 1}: {exc}")
            continue
        target = after[step.subject].position
        moves.append(PlannedMove(step.subject, (target[0], target[1]), -1, None, step))
        state = after
    return ReplayPlan("program", tuple(moves), tuple(refused))


# -- geometry of supports ---------------------------------------------------------------
def _top(objects: Sequence[SceneObject], state: State, j: int) -> float:
    return state[j].position[2] + objects[j].extents[2] / 2.0


def _on_footprint(objects: Sequence[SceneObject], state: State, j: int,
                  xy: Vec) -> bool:
    """Whether the point ``xy`` lies on object ``j``'s top face (its yawed footprint)."""
    p = state[j].position
    yaw = state[j].yaw
    dx, dy = xy[0] - p[0], xy[1] - p[1]
    u = math.cos(yaw) * dx + math.sin(yaw) * dy
    v = -math.sin(yaw) * dx + math.cos(yaw) * dy
    ex, ey, _ = objects[j].extents
    return abs(u) <= ex / 2.0 and abs(v) <= ey / 2.0


def _covered(objects: Sequence[SceneObject], state: State, j: int,
             exclude: Sequence[int]) -> bool:
    return any(rests_on(objects, state, k, j) for k in range(len(objects)) if k not in exclude)


def _overlaps_on_table(objects: Sequence[SceneObject], state: State, subject: int,
                       xy: Vec, ignore: Sequence[int]) -> bool:
    """Whether ``subject`` centred at ``xy`` on the table overlaps another object."""
    pose = Pose((xy[0], xy[1], TABLE_TOP_Z + objects[subject].extents[2] / 2.0),
                state[subject].orientation)
    hs = footprint_half(objects[subject], pose)
    for j, (obj, p) in enumerate(zip(objects, state, strict=True)):
        if j == subject or j in ignore:
            continue
        if p.position[2] - obj.extents[2] / 2.0 > TABLE_TOP_Z + 0.01:
            continue  # not on the table
        hj = footprint_half(obj, p)
        if all(abs(xy[k] - p.position[k]) < hs[k] + hj[k] - _OVERLAP_TOL for k in range(2)):
            return True
    return False


# -- positions -------------------------------------------------------------------------
def plan_from_positions(objects: Sequence[SceneObject], initial: State,
                        positions: NDArray[Any]) -> ReplayPlan:
    """Move every object whose predicted centre is far from its initial one."""
    pos = np.asarray(positions, dtype=np.float64).reshape(len(objects), 3)
    moved = [i for i in range(len(objects))
             if float(np.linalg.norm(pos[i] - np.asarray(initial[i].position))) > MOVE_THRESHOLD]
    planned = _planned_state(objects, initial, {i: tuple(pos[i]) for i in moved})
    moves: list[PlannedMove] = []
    for i in moved:
        bottom = pos[i][2] - objects[i].extents[2] / 2.0
        support = -1
        best = _SUPPORT_Z_TOL
        for j in range(len(objects)):
            if j == i:
                continue
            gap = abs(bottom - _top(objects, planned, j))
            if gap <= best and _on_footprint(objects, planned, j, pos[i][:2]):
                best, support = gap, j
        moves.append(_move(i, pos[i][:2], support, planned))
    return order_moves(objects, initial, "positions", moves)


def _planned_state(objects: Sequence[SceneObject], initial: State,
                   where: dict[int, tuple[float, ...]]) -> State:
    return tuple(
        Pose((float(where[i][0]), float(where[i][1]), float(where[i][2])), p.orientation)
        if i in where else p
        for i, p in enumerate(initial)
    )


def _move(subject: int, xy: Vec, support: int, planned: State) -> PlannedMove:
    sxy = None if support < 0 else (planned[support].position[0], planned[support].position[1])
    return PlannedMove(subject, (float(xy[0]), float(xy[1])), support, sxy)


# -- boxes -----------------------------------------------------------------------------
def box_of(camera: Camera, obj: SceneObject, position: Vec,
           orientation: Vec) -> F64:
    """The amodal box (4,) of ``obj`` at a pose, through ``camera``."""
    out: F64 = camera.amodal_boxes(np.asarray([obj.extents]), np.asarray([position]),
                                   np.asarray([orientation]))[0].astype(np.float64)
    return out


def fit_box_on_plane(camera: Camera, obj: SceneObject, orientation: Vec,
                     box: Vec, z: float) -> F64 | None:
    """The centre ``(3,)`` at height ``z`` whose projected amodal box has ``box``'s centre.

    Starts from the ray through the box centre and corrects the aim point by the residual
    between the boxes' centres (a fixed point; converges in a few steps because the
    projected box centre moves almost one for one with the aim point).
    """
    b = np.asarray(box, dtype=np.float64)
    want = np.array([(b[0] + b[2]) / 2.0, (b[1] + b[3]) / 2.0])
    aim = want.copy()
    point = camera.ray_at_height(aim, z)
    if point is None:
        return None
    for _ in range(_FIT_ITERATIONS):
        got = box_of(camera, obj, point, orientation)
        centre = np.array([(got[0] + got[2]) / 2.0, (got[1] + got[3]) / 2.0])
        residual = want - centre
        if float(np.max(np.abs(residual))) < 0.01:
            break
        aim = aim + residual
        nxt = camera.ray_at_height(aim, z)
        if nxt is None:
            break
        point = nxt
    return point


def _fit_box(camera: Camera, objects: Sequence[SceneObject], planned: State, i: int,
             box: F64, candidates: Sequence[int]) -> tuple[F64, int, float]:
    """Best (centre, support, IoU) for object ``i``'s predicted ``box``."""
    obj = objects[i]
    orn = planned[i].orientation
    half = obj.extents[2] / 2.0
    best: tuple[float, bool, F64, int] | None = None
    for support in (-1, *candidates):
        z = TABLE_TOP_Z + half if support < 0 else _top(objects, planned, support) + half
        point = fit_box_on_plane(camera, obj, orn, box, z)
        if point is None:
            continue
        iou = float(box_iou(box_of(camera, obj, point, orn), box))
        if support < 0:
            valid = not _overlaps_on_table(objects, planned, i, point[:2], ignore=())
        else:
            valid = _on_footprint(objects, planned, support, point[:2])
        key = (iou if valid else iou - 1.0, support < 0)
        if best is None or key > (best[0], best[1]):
            best = (key[0], key[1], point, support)
    if best is None:
        msg = (
            f"the predicted box {box.tolist()} of object {i} cannot be back-projected onto "
            "the table (its centre lies above the horizon); predict a box on the table"
        )
        raise InvalidArgument(msg)
    return best[2], best[3], best[0]


def plan_from_boxes(camera: Camera, objects: Sequence[SceneObject], initial: State,
                    boxes: NDArray[Any]) -> ReplayPlan:
    """Back-project each predicted box whose object would move to a target centre."""
    n = len(objects)
    pred = np.asarray(boxes, dtype=np.float64).reshape(n, 4)
    first: dict[int, tuple[float, ...]] = {}
    for i in range(n):
        point, _, _ = _fit_box(camera, objects, initial, i, pred[i],
                               [j for j in range(n) if j != i])
        if float(np.linalg.norm(point - np.asarray(initial[i].position))) > MOVE_THRESHOLD:
            first[i] = tuple(point)
    # Second pass: an object may rest on another moved object, at its planned place.
    planned = _planned_state(objects, initial, first)
    moves: list[PlannedMove] = []
    for i in sorted(first):
        point, support, _ = _fit_box(camera, objects, planned, i, pred[i],
                                     [j for j in range(n) if j != i])
        moves.append(_move(i, point[:2], support, planned))
    return order_moves(objects, initial, "boxes", moves)


# -- ordering ----------------------------------------------------------------------------
def _target_pose(objects: Sequence[SceneObject], initial: State,
                 by_subject: dict[int, PlannedMove], m: PlannedMove, depth: int = 0) -> Pose:
    """Where ``m`` puts its object (on its support's planned place, if that moves too)."""
    obj = objects[m.subject]
    if m.support < 0:
        bottom = TABLE_TOP_Z
    elif m.support in by_subject and depth < len(objects):
        below = _target_pose(objects, initial, by_subject, by_subject[m.support], depth + 1)
        bottom = below.position[2] + objects[m.support].extents[2] / 2.0
    else:
        bottom = _top(objects, initial, m.support)
    return Pose((m.xy[0], m.xy[1], bottom + obj.extents[2] / 2.0),
                initial[m.subject].orientation)


def _blocks(objects: Sequence[SceneObject], pose: Pose, subject: int, k: int,
            at: Pose) -> bool:
    """Whether object ``k`` at ``at`` overlaps ``subject`` placed at ``pose``."""
    hs = footprint_half(objects[subject], pose)
    hk = footprint_half(objects[k], at)
    return all(
        abs(pose.position[a] - at.position[a]) < hs[a] + hk[a] - (_OVERLAP_TOL if a < 2 else 0.0)
        for a in range(3)
    )


def order_moves(objects: Sequence[SceneObject], initial: State, source: str,
                moves: Sequence[PlannedMove]) -> ReplayPlan:
    """Order ``moves`` so that each can be carried out when its turn comes.

    An object resting on another moves first; a support moves before what it will carry;
    an object standing where another one goes moves first. A move is refused when its
    object is covered by one that stays, when its support is covered by one that stays, or
    when an object that stays occupies its target.
    """
    moving = {m.subject for m in moves}
    all_moves = {m.subject: m for m in moves}
    refused: list[str] = []
    kept: list[PlannedMove] = []
    targets: dict[int, Pose] = {}
    for m in moves:
        if _covered(objects, initial, m.subject, exclude=tuple(moving)):
            refused.append(f"object {m.subject} is covered by an object that stays; not moved")
            continue
        if m.support >= 0 and m.support not in moving and _covered(
                objects, initial, m.support, exclude=tuple(moving)):
            refused.append(f"object {m.subject}: its support {m.support} is covered; not moved")
            continue
        target = _target_pose(objects, initial, all_moves, m)
        blocker = next((k for k in range(len(objects)) if k != m.subject and k not in moving
                        and k != m.support and _blocks(objects, target, m.subject, k,
                                                       initial[k])), None)
        if blocker is not None:
            refused.append(f"object {m.subject}: object {blocker} stands at its target "
                           f"({target.position[0]:.3f}, {target.position[1]:.3f}); not moved")
            continue
        kept.append(m)
        targets[m.subject] = target
    by_subject = {m.subject: m for m in kept}
    before: dict[int, set[int]] = {m.subject: set() for m in kept}
    for m in kept:
        if m.support in by_subject:
            before[m.subject].add(m.support)  # the support goes first
        for k in by_subject:
            if k == m.subject:
                continue
            if rests_on(objects, initial, k, m.subject):
                before[m.subject].add(k)  # what rests on it goes first
            elif k != m.support and _blocks(objects, targets[m.subject], m.subject, k,
                                            initial[k]):
                before[m.subject].add(k)  # what stands at its target goes first
    ordered: list[PlannedMove] = []
    done: set[int] = set()
    pending = sorted(by_subject)
    while pending:
        ready = [s for s in pending if before[s] <= done]
        pick = ready[0] if ready else pending[0]  # a cycle: break it by index
        ordered.append(by_subject[pick])
        done.add(pick)
        pending.remove(pick)
    return ReplayPlan(source, tuple(ordered), tuple(refused))
