"""The Panda carries out manipulation steps by pick-and-place.

For one step (:func:`execute_step`) the controller

1. moves in joint space from where the arm is to above the subject, opening the hand;
2. descends straight down to the grasp point (the middle of the object's body);
3. closes the fingers, which a gear constraint couples so the object stays centred;
4. lifts straight up to the transfer height, which clears every object near the path;
5. measures how the object sits in the hand and carries it to above the target;
6. descends until the object's bottom is :data:`RELEASE_GAP` above its resting height;
7. opens the hand, retreats straight up and returns to the rest pose in joint space;
8. lets the objects settle and checks the result.

The hand's yaw is chosen so that fingers and hand keep clear of neighbours at both ends
(:mod:`.grasp`); Cartesian moves are straight lines tracked by inverse kinematics
and joint position control (:mod:`.control`). Joint positions, end-effector pose
and gripper opening are recorded at the profile's fixed rate.

A step succeeds (:class:`SuccessCriterion`) when the object rests within 1.5 cm of its
target, upright (tilt below 10 degrees), everything is at rest, and no other object was
pushed more than 1 cm. The controller never looks at the gold result: it reads the
object's pose in the hand after lifting (as a wrist camera would), nothing else.

:func:`execute_program` runs every step of a grounded program; by default each step's
target is recomputed with the symbolic action geometry on the *physical* state before the
step (so a stack is built on where the lower object really is), and each step is also
compared with the symbolic target.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.dsl.actions import target_pose
from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.episode import Trajectory
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.generators.robot.control import (
    ArmController,
    panda_joints,
    robot_session,
)
from nsrmp_bench.generators.robot.grasp import (
    GraspPlan,
    choose_grasp_yaw,
    grasp_height,
    obstacles,
    release_lift,
    travel_height,
    wrap_angle,
)
from nsrmp_bench.generators.robot.profiles import (
    ROBOT_EXECUTOR_ID,
    MotionProfile,
    get_profile,
)
from nsrmp_bench.generators.robot.recorder import (
    TrajectoryRecorder,
    concatenate_trajectories,
    empty_trajectory,
)
from nsrmp_bench.generators.world.realise import tilt_deg
from nsrmp_bench.generators.world.world import PANDA_BASE, PANDA_REST, World
from nsrmp_bench.scene import Pose, Scene, SceneObject, State

__all__ = [
    "RELEASE_GAP",
    "SUCCESS",
    "ProgramResult",
    "StepResult",
    "SuccessCriterion",
    "execute_program",
    "execute_step",
    "poses_to_state",
    "robot_joint_names",
]

F64 = NDArray[np.float64]

RELEASE_GAP: Final = 0.002
"""The object's bottom is this far (m) above its resting height when the hand opens."""
_TRAVEL_CLEARANCE: Final = 0.03  # m between the held object's bottom and obstacles
_MIN_LIFT: Final = 0.06  # m the grasp point rises at least above pick and place
_RETREAT: Final = 0.06  # m straight up after releasing
_GRASP_LOST: Final = 0.02  # m: the object lags the hand by more than this after lifting
_SETTLE_STEPS: Final = 240


@dataclass(frozen=True)
class SuccessCriterion:
    """When a pick-and-place counts as a success."""

    position_m: float = 0.015
    tilt_deg: float = 10.0
    disturbed_m: float = 0.01

    def to_dict(self) -> dict[str, float]:
        """Plain JSON-able form."""
        return {"position_m": self.position_m, "tilt_deg": self.tilt_deg,
                "disturbed_m": self.disturbed_m}


SUCCESS: Final = SuccessCriterion()
"""The stated tolerance: 1.5 cm, upright within 10 degrees, neighbours moved < 1 cm."""


@dataclass(frozen=True, eq=False)
class StepResult:
    """What one pick-and-place did.

    ``error_m``: distance from the achieved object centre to the commanded ``target``.
    ``symbolic_error_m``: distance to the symbolic target (``nan`` when none was given).
    ``disturbed_m``: largest displacement of any other object. ``problem`` names the first
    failed condition (``grasp_failed``, ``off_target``, ``tilted``, ``unstable``,
    ``disturbed``) or is None on success. ``release_drop_m``: how far above its resting
    height the object was let go (0 unless neighbours left the open fingers no room).
    """

    subject: int
    target: Pose
    achieved: Pose
    error_m: float
    tilt_deg: float
    stable: bool
    disturbed_m: float
    grasped: bool
    success: bool
    problem: str | None
    symbolic_error_m: float
    grasp: GraspPlan
    physics_steps: int
    sim_time: float
    trajectory: Trajectory
    release_drop_m: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able summary (without the trajectory)."""
        return {
            "subject": self.subject,
            "target": self.target.to_dict(),
            "achieved": self.achieved.to_dict(),
            "error_m": self.error_m,
            "symbolic_error_m": None if math.isnan(self.symbolic_error_m)
            else self.symbolic_error_m,
            "tilt_deg": self.tilt_deg,
            "stable": self.stable,
            "disturbed_m": self.disturbed_m,
            "grasped": self.grasped,
            "success": self.success,
            "problem": self.problem,
            "physics_steps": self.physics_steps,
            "sim_time": self.sim_time,
            "release_drop_m": self.release_drop_m,
        }


@dataclass(frozen=True, eq=False)
class ProgramResult:
    """Every step's result, the whole trajectory and the final object poses ``(N, 7)``."""

    steps: tuple[StepResult, ...]
    trajectory: Trajectory
    final_poses: F64
    profile: MotionProfile
    criterion: SuccessCriterion = SUCCESS
    physics: dict[str, Any] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        """Every step succeeded."""
        return all(s.success for s in self.steps)

    @property
    def final_state(self) -> State:
        """The final poses as a state."""
        return poses_to_state(self.final_poses)

    def summary(self) -> dict[str, Any]:
        """Plain JSON-able summary: the executor id, profile, criterion and every step."""
        return {
            "executor": ROBOT_EXECUTOR_ID,
            "profile": self.profile.to_dict(),
            "criterion": self.criterion.to_dict(),
            "success": self.success,
            "steps": [s.to_dict() for s in self.steps],
            **self.physics,
        }


def poses_to_state(poses: NDArray[Any]) -> State:
    """``(N, 7)`` position + xyzw rows as a tuple of :class:`Pose`."""
    p = np.asarray(poses, dtype=np.float64)
    return tuple(
        Pose((float(r[0]), float(r[1]), float(r[2])),
             (float(r[3]), float(r[4]), float(r[5]), float(r[6])))
        for r in p
    )


def robot_joint_names(world: World) -> tuple[str, ...]:
    """Names of the recorded joints (7 arm joints, then 2 finger joints)."""
    return panda_joints(world).names


def _current_state(world: World) -> State:
    return poses_to_state(world.poses())


def _pick_and_place(
    ctl: ArmController,
    objects: Sequence[SceneObject],
    subject: int,
    target: Pose,
    rest: Sequence[float],
    rest_fingers: float,
    go_to_rest: bool,
) -> tuple[bool, GraspPlan, float]:
    """Run the phases of one step; returns whether the object stayed in the hand, the
    grasp plan and how far above its resting height the object was let go."""
    world = ctl.world
    state = _current_state(world)
    obj = objects[subject]
    pick = state[subject]
    # Obstacles: everything but the subject, where it is now.
    others = obstacles(objects, state, exclude=(subject,))
    # At the target, the object it will rest on is no obstacle for the fingers below the
    # object's bottom (they stay above it), so it is treated like any other object.
    z_place_grasp = grasp_height(obj, target) + RELEASE_GAP
    plan = choose_grasp_yaw(obj, pick, target, others, others, PANDA_BASE, z_place_grasp)
    z_pick_grasp = grasp_height(obj, pick)
    hang = z_pick_grasp - (pick.position[2] - obj.extents[2] / 2.0)
    z_travel = max(
        travel_height(pick.position, target.position, others, hang, _TRAVEL_CLEARANCE),
        z_pick_grasp + _MIN_LIFT,
        z_place_grasp + _MIN_LIFT,
    )
    px, py = pick.position[0], pick.position[1]
    above_pick = (px, py, z_travel)
    grasp_at = (px, py, z_pick_grasp)

    # 1. to above the subject, hand open
    q_above = ctl.solve_ik(above_pick, plan.pick_yaw)
    ctl.move_joints(q_above, gripper=plan.opening)
    ctl.hold_pose(above_pick, plan.pick_yaw, ctl.profile.hold_time)
    # 2. descend, 3. grasp, 4. lift
    ctl.move_line(None, grasp_at, plan.pick_yaw, plan.pick_yaw)
    ctl.gripper_wait(0.0, ctl.profile.close_time, grasp_at, plan.pick_yaw)
    ctl.move_line(grasp_at, above_pick, plan.pick_yaw, plan.pick_yaw)

    # 5. where the object sits in the hand, and where the hand must go to place it
    ee_pos, _ = ctl.ee_pose()
    held = _current_state(world)[subject]
    offset = np.asarray(held.position) - ee_pos
    grasped = offset[2] > -(hang + _GRASP_LOST) and float(np.linalg.norm(offset[:2])) < 0.03
    c0, s0 = math.cos(plan.pick_yaw), math.sin(plan.pick_yaw)
    local = np.array([c0 * offset[0] + s0 * offset[1], -s0 * offset[0] + c0 * offset[1]])
    rel_yaw = wrap_angle(held.yaw - plan.pick_yaw)
    place_yaw = target.yaw - rel_yaw  # the object ends at the target's yaw exactly
    place_yaw += round((plan.place_yaw - place_yaw) / (2.0 * math.pi)) * 2.0 * math.pi
    c1, s1 = math.cos(place_yaw), math.sin(place_yaw)
    tx, ty, tz = target.position
    ex = tx - (c1 * local[0] - s1 * local[1])
    ey = ty - (s1 * local[0] + c1 * local[1])
    bottom_rest = tz - obj.extents[2] / 2.0
    ez = bottom_rest + RELEASE_GAP + (ee_pos[2] - (held.position[2] - obj.extents[2] / 2.0))
    # No room for the open fingers beside the target: open higher and let the object drop.
    drop = release_lift((ex, ey), place_yaw, ez, plan.opening, others)
    ez += drop
    above_place = (ex, ey, max(z_travel, ez + _MIN_LIFT))
    place_at = (ex, ey, ez)

    if not grasped:  # nothing in the hand: open, and back to rest
        ctl.gripper_wait(plan.opening, ctl.profile.open_time, above_pick, plan.pick_yaw)
        ctl.move_joints(rest, gripper=rest_fingers)
        return False, plan, 0.0

    # 6. carry and lower, 7. release and retreat
    ctl.move_line(above_pick, above_place, plan.pick_yaw, place_yaw)
    ctl.move_line(above_place, place_at, place_yaw, place_yaw)
    ctl.gripper_wait(plan.opening, ctl.profile.open_time, place_at, place_yaw)
    retreat = (ex, ey, max(ez + _RETREAT, min(z_travel, ez + 2 * _RETREAT)))
    ctl.move_line(place_at, retreat, place_yaw, place_yaw, hold=0.0)
    if go_to_rest:
        ctl.move_joints(rest, gripper=rest_fingers)
    return grasped, plan, drop


def _joint_state(world: World, joints: Sequence[int]) -> list[float]:
    pb, c = world.pb, world.client
    return [float(s[0]) for s in pb.getJointStates(world.panda, list(joints),
                                                   physicsClientId=c)]


def execute_step(
    world: World,
    subject_index: int,
    target: Pose,
    profile: str | MotionProfile = "fast",
    *,
    step_index: int = 0,
    t0: float = 0.0,
    symbolic_target: Pose | None = None,
    criterion: SuccessCriterion = SUCCESS,
    go_to_rest: bool = True,
) -> StepResult:
    """Pick object ``subject_index`` of the World's current instance and place it at
    ``target`` (its centre's pose), then let everything settle and judge the result.

    The World must hold the instance already (:meth:`World.begin` and objects placed).
    ``step_index`` and ``t0`` label the recorded samples (program step, start time);
    ``symbolic_target`` is only compared with. With ``go_to_rest`` off the arm stays above
    the target after retreating (out of the camera's way only at rest).
    """
    prof = get_profile(profile)
    n = len(world.bodies)
    if not 0 <= subject_index < n:
        msg = (
            f"subject index {subject_index} is out of range: the World's instance has "
            f"objects 0..{n - 1}; call World.begin(scene.objects) and place them first"
        )
        raise InvalidArgument(msg)
    objects = world.objects
    before = world.poses()
    with robot_session(world, prof) as (joints, dt):
        every = max(1, round(1.0 / (prof.record_hz * dt)))
        recorder = TrajectoryRecorder(
            world.pb, world.client, int(world.panda or 0), joints.arm, joints.fingers,
            joints.ee, joints.names, every, dt, t0)
        recorder.step_index = step_index
        recorder.sample()
        ctl = ArmController(world, prof, recorder, joints, dt)
        rest = list(PANDA_REST)
        rest_fingers = float(np.mean(_joint_state(world, joints.fingers)))
        grasped, plan, drop = _pick_and_place(ctl, objects, subject_index, target, rest,
                                              rest_fingers, go_to_rest)
        moving_steps = ctl.steps
        moving_time = recorder.time - t0
    settle = world.settle(max_steps=_SETTLE_STEPS)
    after = world.poses()
    achieved = poses_to_state(after[subject_index : subject_index + 1])[0]
    err = math.dist(achieved.position, target.position)
    sym_err = (math.nan if symbolic_target is None
               else math.dist(achieved.position, symbolic_target.position))
    tilt = float(tilt_deg(np.asarray(achieved.orientation, dtype=np.float64)))
    moved = np.linalg.norm(after[:, :3] - before[:, :3], axis=1)
    moved[subject_index] = 0.0
    disturbed = float(moved.max()) if n > 1 else 0.0
    problem: str | None = None
    if not grasped:
        problem = "grasp_failed"
    elif err > criterion.position_m:
        problem = "off_target"
    elif tilt > criterion.tilt_deg:
        problem = "tilted"
    elif not settle.settled:
        problem = "unstable"
    elif disturbed > criterion.disturbed_m:
        problem = "disturbed"
    settle_time = settle.steps * world.config.time_step
    return StepResult(
        subject=subject_index,
        target=target,
        achieved=achieved,
        error_m=err,
        tilt_deg=tilt,
        stable=settle.settled,
        disturbed_m=disturbed,
        grasped=grasped,
        success=problem is None,
        problem=problem,
        symbolic_error_m=sym_err,
        grasp=plan,
        physics_steps=moving_steps + settle.steps,
        sim_time=moving_time + settle_time,
        trajectory=recorder.trajectory(),
        release_drop_m=drop,
    )


def execute_program(
    world: World,
    scene: Scene,
    states: Sequence[State] | None,
    grounded: Sequence[GroundedStep],
    profile: str | MotionProfile = "fast",
    *,
    retarget: bool = True,
    criterion: SuccessCriterion = SUCCESS,
    on_step: Callable[[int, StepResult], None] | None = None,
    stop_on_failure: bool = False,
    rest_between_steps: bool = True,
) -> ProgramResult:
    """Carry out ``grounded`` step by step with the Panda, from the World's current state.

    The World must hold ``scene``'s instance at its initial state. With ``retarget`` each
    step's target is :func:`~nsrmp_bench.dsl.actions.target_pose` on the physical state
    before it; otherwise it is the symbolic ``states[k + 1]``. ``states`` (the symbolic
    states, initial first) may be None when ``retarget`` is on. ``on_step(k, result)``
    runs after each step (e.g. to render); the arm is at rest by then unless
    ``rest_between_steps`` is off (faster: the arm goes from one place to the next pick,
    and rests after the last step). ``stop_on_failure`` skips the steps after a failed
    one.
    """
    prof = get_profile(profile)
    if tuple(world.objects) != tuple(scene.objects):
        msg = (
            "the World holds another instance than the scene given "
            f"({len(world.objects)} objects vs {len(scene.objects)}); call "
            "World.begin(scene.objects) and place the objects first"
        )
        raise InvalidArgument(msg)
    if states is not None and len(states) != len(grounded) + 1:
        msg = (
            f"need steps+1 states (initial and after each step), got {len(states)} states "
            f"for {len(grounded)} steps"
        )
        raise InvalidArgument(msg)
    if states is None and not retarget:
        msg = "execute_program needs the symbolic states when retarget=False; pass states"
        raise InvalidArgument(msg)
    results: list[StepResult] = []
    t = 0.0
    for k, step in enumerate(grounded):
        if retarget:
            current = _current_state(world)
            target = target_pose(scene.objects, current, step.action, step.subject,
                                 step.reference)
        else:
            assert states is not None
            target = states[k + 1][step.subject]
        symbolic = None if states is None else states[k + 1][step.subject]
        last = k == len(grounded) - 1
        result = execute_step(world, step.subject, target, prof, step_index=k, t0=t,
                              symbolic_target=symbolic, criterion=criterion,
                              go_to_rest=rest_between_steps or last)
        t += result.sim_time
        results.append(result)
        if on_step is not None:
            on_step(k, result)
        if stop_on_failure and not result.success:
            break
    traj = (concatenate_trajectories([r.trajectory for r in results]) if results
            else empty_trajectory(robot_joint_names(world)))
    physics = {
        "physics_steps": int(sum(r.physics_steps for r in results)),
        "sim_time": float(t),
    }
    return ProgramResult(tuple(results), traj, world.poses(), prof, criterion, physics)
