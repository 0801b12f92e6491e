"""The geometry of manipulation steps, and the named checks that make a step legal.

A step ``(action, subject, reference)`` moves the subject next to the reference:

* ``top``: centred on the reference, resting on its top face (true heights of both);
* ``left`` / ``right``: on the table beside the reference along world x, the footprints
  ``PLACEMENT_MARGIN`` apart (true extents with each object's yaw).

The moved object keeps its yaw. Every check below is a named function that returns a
reason code (or None); :func:`step_problem` runs them in order and :func:`apply_step`
raises :class:`~nsrmp_bench.errors.InfeasibleStep` with the first problem.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.errors import InfeasibleStep, InvalidArgument
from nsrmp_bench.scene import Pose, SceneObject, State
from nsrmp_bench.vocabulary import ACTIONS, PLACEMENT_MARGIN, TABLE_TOP_Z, TARGET_AREA, Area

__all__ = [
    "CHECKS",
    "MAX_STACK",
    "apply_step",
    "changes_nothing",
    "feasible_steps",
    "footprint_half",
    "is_self_move",
    "off_table",
    "reference_covered",
    "rests_on",
    "step_problem",
    "subject_covered",
    "target_occupied",
    "target_pose",
    "too_high",
]

MAX_STACK = 3
"""Most objects in one stack (stability and visibility)."""

_CONTACT_TOL = 0.006  # m: a bottom face this close to a top face rests on it
_CLEARANCE = 0.004  # m: minimum gap between a placed object and its neighbours
_NO_CHANGE_TOL = 0.01  # m: a target this close to the current position changes nothing


def footprint_half(obj: SceneObject, pose: Pose) -> tuple[float, float, float]:
    """Half extents (x, y, z) of the object's world axis-aligned box at ``pose`` (yaw only)."""
    ex, ey, ez = obj.extents
    yaw = pose.yaw
    c, s = abs(math.cos(yaw)), abs(math.sin(yaw))
    return ((ex * c + ey * s) / 2.0, (ex * s + ey * c) / 2.0, ez / 2.0)


def _box(obj: SceneObject, pose: Pose) -> tuple[tuple[float, ...], tuple[float, ...]]:
    h = footprint_half(obj, pose)
    p = pose.position
    return tuple(p[k] - h[k] for k in range(3)), tuple(p[k] + h[k] for k in range(3))


def _overlap_xy(a: SceneObject, pa: Pose, b: SceneObject, pb: Pose, pad: float = 0.0) -> bool:
    (alo, ahi), (blo, bhi) = _box(a, pa), _box(b, pb)
    return all(alo[k] < bhi[k] + pad and blo[k] < ahi[k] + pad for k in range(2))


def rests_on(objects: Sequence[SceneObject], state: State, upper: int, lower: int) -> bool:
    """Whether object ``upper`` sits on object ``lower`` (bottom face on top face, overlapping)."""
    if upper == lower:
        return False
    top_of_lower = state[lower].position[2] + objects[lower].extents[2] / 2.0
    bottom_of_upper = state[upper].position[2] - objects[upper].extents[2] / 2.0
    return abs(bottom_of_upper - top_of_lower) < _CONTACT_TOL and _overlap_xy(
        objects[upper], state[upper], objects[lower], state[lower]
    )


def _stack_level(objects: Sequence[SceneObject], state: State, i: int) -> int:
    """1 for an object on the table, 2 for one on another object, ..."""
    for j in range(len(objects)):
        if rests_on(objects, state, i, j):
            return 1 + _stack_level(objects, state, j)
    return 1


def target_pose(
    objects: Sequence[SceneObject], state: State, action: str, subject: int, reference: int
) -> Pose:
    """Where ``action`` puts ``subject`` relative to ``reference`` in ``state``."""
    if action not in ACTIONS:
        msg = f"unknown action {action!r}; expected one of {list(ACTIONS)}"
        raise InvalidArgument(msg)
    sub, ref = objects[subject], objects[reference]
    ps, pr = state[subject], state[reference]
    rx, ry, rz = pr.position
    if action == "top":
        z = rz + ref.extents[2] / 2.0 + sub.extents[2] / 2.0
        return Pose((rx, ry, round(z, 6)), ps.orientation)
    gap = footprint_half(ref, pr)[0] + footprint_half(sub, ps)[0] + PLACEMENT_MARGIN
    x = rx - gap if action == "left" else rx + gap
    return Pose((round(x, 6), ry, round(TABLE_TOP_Z + sub.extents[2] / 2.0, 6)), ps.orientation)


# -- named checks: each returns a reason code, or None when the step passes -----------
StepCheck = Callable[[Sequence[SceneObject], State, GroundedStep, Area], "str | None"]


def is_self_move(
    objects: Sequence[SceneObject], state: State, step: GroundedStep,
    workspace: Area = TARGET_AREA,
) -> str | None:
    """The step moves an object relative to itself."""
    return "self_move" if step.subject == step.reference else None


def subject_covered(
    objects: Sequence[SceneObject], state: State, step: GroundedStep,
    workspace: Area = TARGET_AREA,
) -> str | None:
    """Something rests on the object to move, so it cannot be picked up."""
    covered = any(rests_on(objects, state, j, step.subject) for j in range(len(objects)))
    return "subject_covered" if covered else None


def reference_covered(
    objects: Sequence[SceneObject], state: State, step: GroundedStep,
    workspace: Area = TARGET_AREA,
) -> str | None:
    """A ``top`` step onto an object that already carries another object."""
    if step.action != "top":
        return None
    covered = any(
        rests_on(objects, state, j, step.reference)
        for j in range(len(objects))
        if j != step.subject
    )
    return "reference_covered" if covered else None


def moves_onto_support(
    objects: Sequence[SceneObject], state: State, step: GroundedStep,
    workspace: Area = TARGET_AREA,
) -> str | None:
    """A ``top`` step onto the object the subject already rests on (or one below it)."""
    if step.action != "top":
        return None
    i = step.subject
    seen = 0
    while seen < len(objects):
        below = next((j for j in range(len(objects)) if rests_on(objects, state, i, j)), None)
        if below is None:
            return None
        if below == step.reference:
            return "onto_support"
        i = below
        seen += 1
    return None


def too_high(
    objects: Sequence[SceneObject], state: State, step: GroundedStep,
    workspace: Area = TARGET_AREA,
) -> str | None:
    """A ``top`` step that would make a stack taller than :data:`MAX_STACK`."""
    if step.action != "top":
        return None
    return "too_high" if _stack_level(objects, state, step.reference) + 1 > MAX_STACK else None


def off_table(
    objects: Sequence[SceneObject], state: State, step: GroundedStep,
    workspace: Area = TARGET_AREA,
) -> str | None:
    """The target centre falls outside the scene's workspace (ours: off the table or out of
    view)."""
    x, y, _ = target_pose(objects, state, step.action, step.subject, step.reference).position
    return None if workspace.contains(x, y) else "off_table"


def changes_nothing(
    objects: Sequence[SceneObject], state: State, step: GroundedStep,
    workspace: Area = TARGET_AREA,
) -> str | None:
    """The target is where the subject already is."""
    t = target_pose(objects, state, step.action, step.subject, step.reference).position
    p = state[step.subject].position
    return "no_change" if math.dist(t, p) < _NO_CHANGE_TOL else None


def target_occupied(
    objects: Sequence[SceneObject], state: State, step: GroundedStep,
    workspace: Area = TARGET_AREA,
) -> str | None:
    """The subject at its target would overlap another object (other than its support)."""
    t = target_pose(objects, state, step.action, step.subject, step.reference)
    sub = objects[step.subject]
    lo, hi = _box(sub, t)
    for j, (obj, pose) in enumerate(zip(objects, state, strict=True)):
        if j == step.subject or (step.action == "top" and j == step.reference):
            continue
        olo, ohi = _box(obj, pose)
        pad = _CLEARANCE
        if all(lo[k] < ohi[k] + pad and olo[k] < hi[k] + pad for k in range(2)) and (
            lo[2] < ohi[2] - _CONTACT_TOL and olo[2] < hi[2] - _CONTACT_TOL
        ):
            return "target_occupied"
    return None


CHECKS: tuple[StepCheck, ...] = (
    is_self_move,
    subject_covered,
    moves_onto_support,
    reference_covered,
    too_high,
    off_table,
    changes_nothing,
    target_occupied,
)
"""The step checks, in the order they are applied."""

_FIXES = {
    "self_move": "choose a reference object different from the subject",
    "subject_covered": "move the object resting on it first",
    "onto_support": "the object already rests on that stack; choose another reference",
    "reference_covered": "put it on an object with a free top face",
    "too_high": f"stacks hold at most {MAX_STACK} objects; choose a lower reference",
    "off_table": "choose a reference further from the table edge or another action",
    "no_change": "the object is already there; choose another step",
    "target_occupied": "the target spot is taken; choose another reference or action",
}


def step_problem(
    objects: Sequence[SceneObject], state: State, step: GroundedStep,
    workspace: Area = TARGET_AREA,
) -> str | None:
    """The first failed check's reason code, or None when the step is legal in
    ``workspace`` (the scene's; ours by default)."""
    n = len(objects)
    for idx in (step.subject, step.reference):
        if not 0 <= idx < n:
            msg = f"object index {idx} out of range; the scene has objects 0..{n - 1}"
            raise InvalidArgument(msg)
    for check in CHECKS:
        reason = check(objects, state, step, workspace)
        if reason is not None:
            return reason
    return None


def apply_step(
    objects: Sequence[SceneObject], state: State, step: GroundedStep,
    workspace: Area = TARGET_AREA,
) -> State:
    """The state after ``step``; raises :class:`InfeasibleStep` if a check fails."""
    reason = step_problem(objects, state, step, workspace)
    if reason is not None:
        msg = (
            f"step {step.action}({step.subject} -> {step.reference}) is not possible: "
            f"{reason}; {_FIXES[reason]}"
        )
        raise InfeasibleStep(msg)
    new = target_pose(objects, state, step.action, step.subject, step.reference)
    return tuple(new if i == step.subject else p for i, p in enumerate(state))


def feasible_steps(
    objects: Sequence[SceneObject], state: State, workspace: Area = TARGET_AREA
) -> list[GroundedStep]:
    """Every legal single step in ``state``, in (action, subject, reference) order."""
    out = []
    for action in ACTIONS:
        for s in range(len(objects)):
            for r in range(len(objects)):
                step = GroundedStep(action, s, r)
                if s != r and step_problem(objects, state, step, workspace) is None:
                    out.append(step)
    return out
