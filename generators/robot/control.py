"""Driving the World's Panda: joints, kinematics, a robot session and the arm controller.

:func:`robot_session` prepares the Panda for pick-and-place and undoes it afterwards: it
couples the two fingers with a gear constraint (without it an object slides ~2 cm between
independently controlled fingers), raises finger friction, and switches the physics to the
profile's time step and solver setting. :class:`ArmController` moves the arm: smoothstep
joint-space moves, and straight Cartesian lines tracked by inverse kinematics
(:mod:`.kinematics`) every ``ik_every`` physics steps, with joint velocity feed-forward
so that position control follows the line to a fraction of a millimetre.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.generators.robot.kinematics import PandaKinematics, down_rotation
from nsrmp_bench.generators.robot.profiles import MotionProfile
from nsrmp_bench.generators.robot.recorder import TrajectoryRecorder
from nsrmp_bench.generators.world.world import PANDA_BASE, World

__all__ = [
    "READY",
    "ArmController",
    "PandaJoints",
    "arm_kinematics",
    "panda_joints",
    "posture",
    "robot_session",
    "smoothstep",
]

F64 = NDArray[np.float64]
Vec = Sequence[float] | NDArray[np.float64]

_EE_LINK_NAME: Final = "panda_grasptarget_hand"
_ARM_FORCE: Final = 87.0  # N m, every arm joint
_FINGER_FORCE: Final = 40.0  # N per finger
_GEAR_MAX_FORCE: Final = 50.0
_FINGER_FRICTION: Final = 1.5
_POSITION_GAIN: Final = 0.1
_VELOCITY_GAIN: Final = 1.0
_WORLD_RESIDUAL: Final = 0.0  # World() sets this (every solver iteration runs)
READY: Final = (0.42, 0.36, -0.38, -2.38, 0.31, 2.70, -1.01)
"""Arm joints with the hand pointing down above the workspace: a fallback IK seed."""


def posture(pos: Vec, yaw: float) -> list[float]:
    """A comfortable arm posture for reaching down at ``pos``: joint 1 turned towards it,
    elbow up, joints 3 and 5 untwisted, the wrist turned for ``yaw``."""
    azimuth = math.atan2(pos[1] - PANDA_BASE[1], pos[0] - PANDA_BASE[0]) + math.pi / 2.0
    return [azimuth, 0.4, 0.0, -2.2, 0.0, 2.6, azimuth - math.pi / 2.0 + 0.7 - yaw]


def smoothstep(s: float) -> float:
    """3s^2 - 2s^3: starts and ends at rest."""
    return s * s * (3.0 - 2.0 * s)


@dataclass(frozen=True)
class PandaJoints:
    """Joint indices of the arm and fingers, the grasp-target link, recorded joint names."""

    arm: tuple[int, ...]
    fingers: tuple[int, ...]
    ee: int
    names: tuple[str, ...]


_JOINTS_CACHE: weakref.WeakKeyDictionary[World, PandaJoints] = weakref.WeakKeyDictionary()


def panda_joints(world: World) -> PandaJoints:
    """The World's Panda joints (looked up once per World)."""
    if world.panda is None:
        msg = (
            "this World has no Panda (WorldConfig.panda='none'); robot execution needs one: "
            "build the World with WorldConfig(panda='lean') or 'stock'"
        )
        raise InvalidArgument(msg)
    cached = _JOINTS_CACHE.get(world)
    if cached is not None:
        return cached
    pb, c, body = world.pb, world.client, world.panda
    arm: list[int] = []
    fingers: list[int] = []
    names: list[str] = []
    ee = -1
    for j in range(pb.getNumJoints(body, physicsClientId=c)):
        info = pb.getJointInfo(body, j, physicsClientId=c)
        name = info[1].decode()
        if info[2] == pb.JOINT_REVOLUTE:
            arm.append(j)
        elif info[2] == pb.JOINT_PRISMATIC and "finger" in name:
            fingers.append(j)
        if name == _EE_LINK_NAME:
            ee = j
    if len(arm) != 7 or len(fingers) != 2 or ee < 0:
        msg = (
            f"the World's Panda has {len(arm)} arm joints, {len(fingers)} finger joints and "
            f"{'no' if ee < 0 else 'a'} {_EE_LINK_NAME!r} link; expected pybullet_data's "
            "franka_panda/panda.urdf (7, 2, yes)"
        )
        raise InvalidArgument(msg)
    for j in (*arm, *fingers):
        names.append(pb.getJointInfo(body, j, physicsClientId=c)[1].decode())
    out = PandaJoints(tuple(arm), tuple(fingers), ee, tuple(names))
    _JOINTS_CACHE[world] = out
    return out


_KIN_CACHE: weakref.WeakKeyDictionary[World, PandaKinematics] = weakref.WeakKeyDictionary()


def arm_kinematics(world: World, joints: PandaJoints) -> PandaKinematics:
    """The numpy kinematics of the World's Panda (built once per World)."""
    kin = _KIN_CACHE.get(world)
    if kin is None:
        kin = PandaKinematics(world.pb, world.client, int(world.panda or 0), joints.arm,
                              joints.ee)
        _KIN_CACHE[world] = kin
    return kin


class ArmController:
    """Drives the Panda of one World for the duration of a robot session."""

    def __init__(self, world: World, profile: MotionProfile, recorder: TrajectoryRecorder,
                 joints: PandaJoints, dt: float) -> None:
        self.world = world
        self.pb = world.pb
        self.c = world.client
        self.body = world.panda
        self.profile = profile
        self.rec = recorder
        self.j = joints
        self.dt = dt
        self.steps = 0
        self._arm_forces = [_ARM_FORCE] * len(joints.arm)
        self._finger_target = 0.0
        self._finger_force = _FINGER_FORCE
        self.kin = arm_kinematics(world, joints)
        self._q_ik: F64 | None = None

    # -- low level -------------------------------------------------------------------
    def joint_positions(self) -> F64:
        states = self.pb.getJointStates(self.body, list(self.j.arm), physicsClientId=self.c)
        return np.array([s[0] for s in states], dtype=np.float64)

    def ee_pose(self) -> tuple[F64, F64]:
        ls = self.pb.getLinkState(self.body, self.j.ee, computeForwardKinematics=1,
                                  physicsClientId=self.c)
        return np.asarray(ls[4], dtype=np.float64), np.asarray(ls[5], dtype=np.float64)

    def command_arm(self, q: Vec, qd: Vec | None = None) -> None:
        n = len(self.j.arm)
        self.pb.setJointMotorControlArray(
            self.body, list(self.j.arm), self.pb.POSITION_CONTROL,
            targetPositions=list(q),
            targetVelocities=[0.0] * n if qd is None else list(qd),
            forces=self._arm_forces,
            positionGains=[_POSITION_GAIN] * n,
            velocityGains=[_VELOCITY_GAIN] * n,
            physicsClientId=self.c)

    def command_gripper(self, opening: float, force: float = _FINGER_FORCE) -> None:
        self._finger_target = opening
        self._finger_force = force
        n = len(self.j.fingers)
        self.pb.setJointMotorControlArray(
            self.body, list(self.j.fingers), self.pb.POSITION_CONTROL,
            targetPositions=[opening] * n, forces=[force] * n, physicsClientId=self.c)

    def physics_step(self) -> None:
        self.pb.stepSimulation(physicsClientId=self.c)
        self.steps += 1
        self.rec.tick()

    def ik(self, pos: Vec, yaw: float) -> list[float]:
        """Arm joint targets for the grasp target at ``pos`` pointing down with ``yaw``,
        warm-started from the previous answer (see :mod:`.kinematics`)."""
        seed = self.joint_positions() if self._q_ik is None else self._q_ik
        res = self.kin.ik(pos, down_rotation(yaw), seed, posture(pos, yaw))
        self._q_ik = res.q
        return [float(v) for v in res.q]

    def solve_ik(self, pos: Vec, yaw: float) -> list[float]:
        """Joints for a far-away pose: the better of solving from the current joints and
        from :data:`READY`."""
        rot = down_rotation(yaw)
        rest = posture(pos, yaw)
        best = None
        for seed in (self.joint_positions(), np.asarray(READY)):
            res = self.kin.ik(pos, rot, seed, rest, max_iterations=60)
            if best is None or res.position_error < best.position_error:
                best = res
        assert best is not None
        self._q_ik = best.q
        return [float(v) for v in best.q]

    def _n_steps(self, seconds: float) -> int:
        return max(1, math.ceil(seconds / self.dt))

    # -- motions ---------------------------------------------------------------------
    def move_joints(self, q_goal: Vec, gripper: float | None = None) -> None:
        """Smoothstep joint-space move from the current joint positions."""
        q0 = self.joint_positions()
        q1 = np.asarray(q_goal, dtype=np.float64)
        span = float(np.max(np.abs(q1 - q0)))
        seconds = max(span / self.profile.joint_speed, self.profile.min_segment_time)
        if gripper is not None:
            self.command_gripper(gripper)
        n = self._n_steps(seconds)
        for i in range(1, n + 1):
            u = i / n
            rate = 6.0 * u * (1.0 - u) / (n * self.dt)  # d smoothstep / dt
            self.command_arm(q0 + smoothstep(u) * (q1 - q0), rate * (q1 - q0))
            self.physics_step()
        self.hold_joints(q1, self.profile.hold_time)

    def hold_joints(self, q: Vec, seconds: float) -> None:
        self.command_arm(q)
        for _ in range(self._n_steps(seconds) if seconds > 0 else 0):
            self.physics_step()

    def move_line(self, start: Vec | None, end: Vec, yaw0: float,
                  yaw1: float, hold: float | None = None) -> None:
        """Straight-line Cartesian move of the grasp target with smoothstep timing."""
        p0 = self.ee_pose()[0] if start is None else np.asarray(start, dtype=np.float64)
        p1 = np.asarray(end, dtype=np.float64)
        horizontal = float(np.linalg.norm(p1[:2] - p0[:2]))
        vertical = abs(float(p1[2] - p0[2]))
        turn = abs(yaw1 - yaw0)
        prof = self.profile
        seconds = max(horizontal / prof.travel_speed, vertical / prof.vertical_speed,
                      turn / prof.joint_speed, prof.min_segment_time)
        n = self._n_steps(seconds)
        every = prof.ik_every
        q_prev = self.joint_positions()
        for i in range(1, n + 1):
            if (i - 1) % every == 0:
                ahead = min(n, i + every - 1)
                s = smoothstep(ahead / n)
                q = np.asarray(self.ik(p0 + s * (p1 - p0), yaw0 + s * (yaw1 - yaw0)))
                qd = (q - q_prev) / ((ahead - i + 1) * self.dt)
                self.command_arm(q, qd)
                q_prev = q
            self.physics_step()
        self.hold_pose(p1, yaw1, prof.hold_time if hold is None else hold)

    def hold_pose(self, pos: Vec, yaw: float, seconds: float) -> None:
        n = self._n_steps(seconds) if seconds > 0 else 0
        for i in range(n):
            if i % self.profile.ik_every == 0:
                self.command_arm(self.ik(pos, yaw))
            self.physics_step()

    def gripper_wait(self, opening: float, seconds: float, pos: Vec,
                     yaw: float, force: float = _FINGER_FORCE) -> None:
        self.command_gripper(opening, force)
        self.hold_pose(pos, yaw, max(seconds, self.dt))


@contextmanager
def robot_session(world: World, profile: MotionProfile) -> Iterator[tuple[PandaJoints, float]]:
    """Couple the fingers, set finger friction and the profile's time step; undo after."""
    joints = panda_joints(world)
    pb, c, body = world.pb, world.client, world.panda
    f1, f2 = joints.fingers
    gear = pb.createConstraint(body, f1, body, f2, jointType=pb.JOINT_GEAR,
                               jointAxis=[1, 0, 0], parentFramePosition=[0, 0, 0],
                               childFramePosition=[0, 0, 0], physicsClientId=c)
    pb.changeConstraint(gear, gearRatio=-1, erp=0.1, maxForce=_GEAR_MAX_FORCE,
                        physicsClientId=c)
    friction = {f: pb.getDynamicsInfo(body, f, physicsClientId=c)[1] for f in joints.fingers}
    for f in joints.fingers:
        pb.changeDynamics(body, f, lateralFriction=_FINGER_FRICTION, physicsClientId=c)
    world_dt = world.config.time_step
    dt = world_dt if profile.time_step is None else profile.time_step
    if dt != world_dt:
        pb.setPhysicsEngineParameter(fixedTimeStep=dt, physicsClientId=c)
    residual = profile.solver_residual_threshold
    if residual is not None:
        pb.setPhysicsEngineParameter(solverResidualThreshold=residual, physicsClientId=c)
    try:
        yield joints, dt
    finally:
        if residual is not None:
            restore = float(getattr(world.config, "solver_residual_threshold", _WORLD_RESIDUAL))
            pb.setPhysicsEngineParameter(solverResidualThreshold=restore, physicsClientId=c)
        if dt != world_dt:
            pb.setPhysicsEngineParameter(fixedTimeStep=world_dt, physicsClientId=c)
        for f, mu in friction.items():
            pb.changeDynamics(body, f, lateralFriction=mu, physicsClientId=c)
        pb.removeConstraint(gear, physicsClientId=c)


