"""End-effector control of the Panda at a fixed rate: the environment's ``control="ee"``.

An action is a change of the grasp target's pose, ``(dx, dy, dz, dyaw)`` in metres and
radians (world frame, the hand pointing straight down), and a gripper command in [0, 1]
(0 closed, 1 open: :data:`GRIPPER_OPEN` metres per finger), applied over one control
period (1 / :data:`EE_RATE_HZ` s of simulated time). Each change is clipped to
:data:`MAX_TRANSLATION` per axis and :data:`MAX_YAW`, and the target to
:data:`WORKSPACE`; the arm follows the straight line from the previous target at constant
speed, by the numpy inverse kinematics (:mod:`.kinematics`) every ``ik_every`` physics
steps, as the pick-and-place controller does (:mod:`.control`). The episode starts with the
hand open above the workspace at :data:`HOME`.

The proprioception (12 float32) is the grasp target's measured position (3), its yaw,
the finger opening (m per finger) and the seven arm joints (rad).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from contextlib import ExitStack
from typing import Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidAction
from nsrmp_bench.generators.robot.control import (
    READY,
    ArmController,
    panda_joints,
    posture,
    robot_session,
)
from nsrmp_bench.generators.robot.kinematics import down_rotation
from nsrmp_bench.generators.robot.profiles import get_profile
from nsrmp_bench.generators.robot.recorder import TrajectoryRecorder
from nsrmp_bench.generators.world.world import World
from nsrmp_bench.vocabulary import TABLE_TOP_Z

__all__ = ["EE_RATE_HZ", "GRIPPER_OPEN", "HOME", "MAX_TRANSLATION", "MAX_YAW",
           "PROPRIO_SIZE", "WORKSPACE", "EndEffectorControl", "yaw_of"]

F64 = NDArray[np.float64]

EE_RATE_HZ: Final = 10.0
"""Control steps per second of simulated time."""
MAX_TRANSLATION: Final = 0.05
"""Metres per axis per control step (0.5 m/s at 10 Hz)."""
MAX_YAW: Final = 0.5
"""Radians per control step."""
GRIPPER_OPEN: Final = 0.04
"""Finger opening (m per finger) of the gripper command 1."""
HOME: Final = (0.0, 0.1, TABLE_TOP_Z + 0.30)
"""The grasp target at the start of an episode (yaw 0, hand open)."""
WORKSPACE: Final = ((-0.45, 0.45), (-0.40, 0.50), (TABLE_TOP_Z + 0.003, TABLE_TOP_Z + 0.55))
"""The box (x, y, z bounds in metres) the grasp target is kept in."""
PROPRIO_SIZE: Final = 12


def yaw_of(rotation: F64) -> float:
    """The yaw of a hand rotation that points down (inverse of ``down_rotation``)."""
    return math.atan2(float(rotation[1, 0]), float(rotation[0, 0]))


class EndEffectorControl:
    """The Panda of one World under end-effector control (see the module)."""

    def __init__(self, world: World, profile: str = "fast", rate_hz: float = EE_RATE_HZ) -> None:
        self.world = world
        self.profile = get_profile(profile)
        self.rate_hz = float(rate_hz)
        self._stack: ExitStack | None = None
        self._ctl: ArmController | None = None
        self.target = np.asarray(HOME, dtype=np.float64)
        self.yaw = 0.0
        self.gripper = 1.0

    @property
    def active(self) -> bool:
        """Whether a robot session is open."""
        return self._ctl is not None

    def start(self) -> None:
        """Open the robot session and put the hand, open, at :data:`HOME` (the joints set
        directly, the scene untouched)."""
        self.stop()
        world = self.world
        stack = ExitStack()
        joints, dt = stack.enter_context(robot_session(world, self.profile))
        recorder = TrajectoryRecorder(world.pb, world.client, int(world.panda or 0),
                                      joints.arm, joints.fingers, joints.ee, joints.names,
                                      10**9, dt, 0.0)
        ctl = ArmController(world, self.profile, recorder, joints, dt)
        self.target = np.asarray(HOME, dtype=np.float64)
        self.yaw = 0.0
        self.gripper = 1.0
        rot = down_rotation(0.0)
        q = ctl.kin.ik(self.target, rot, np.asarray(READY), posture(self.target, 0.0),
                       max_iterations=200).q
        pb, c = world.pb, world.client
        for j, v in zip(joints.arm, q, strict=True):
            pb.resetJointState(world.panda, j, float(v), 0.0, physicsClientId=c)
        for j in joints.fingers:
            pb.resetJointState(world.panda, j, GRIPPER_OPEN, 0.0, physicsClientId=c)
        ctl._q_ik = np.asarray(q, dtype=np.float64)
        ctl.command_arm(q)
        ctl.command_gripper(GRIPPER_OPEN)
        self._stack, self._ctl = stack, ctl

    def stop(self) -> None:
        """Close the robot session (restores the world's physics settings)."""
        if self._stack is not None:
            self._stack.close()
        self._stack, self._ctl = None, None

    def step(self, delta: Sequence[float] | F64, gripper: float) -> None:
        """One control period: move the target by ``delta`` (clipped), command the
        gripper, and step the physics."""
        ctl = self._ctl
        if ctl is None:
            msg = "the end-effector control is not started; reset the environment first"
            raise InvalidAction(msg)
        d = np.asarray(delta, dtype=np.float64).reshape(-1)
        if d.shape != (4,) or not np.isfinite(d).all():
            msg = (f"'ee' must be 4 finite numbers (dx, dy, dz in m, dyaw in rad), got "
                   f"{np.asarray(delta).tolist()!r:.80}")
            raise InvalidAction(msg)
        g = float(gripper)
        if not 0.0 <= g <= 1.0:
            msg = f"'gripper' must be in [0, 1] (0 closed, 1 open), got {g}"
            raise InvalidAction(msg)
        p0, yaw0 = self.target.copy(), self.yaw
        step = np.clip(d[:3], -MAX_TRANSLATION, MAX_TRANSLATION)
        p1 = np.array([np.clip(p0[k] + step[k], *WORKSPACE[k]) for k in range(3)])
        yaw1 = yaw0 + float(np.clip(d[3], -MAX_YAW, MAX_YAW))
        if g != self.gripper:
            ctl.command_gripper(g * GRIPPER_OPEN)
            self.gripper = g
        n = max(1, round(1.0 / (self.rate_hz * ctl.dt)))
        every = ctl.profile.ik_every
        q_prev = ctl._q_ik if ctl._q_ik is not None else ctl.joint_positions()
        for i in range(1, n + 1):
            if (i - 1) % every == 0:
                ahead = min(n, i + every - 1)
                s = ahead / n
                q = np.asarray(ctl.ik(p0 + s * (p1 - p0), yaw0 + s * (yaw1 - yaw0)))
                qd = (q - q_prev) / ((ahead - i + 1) * ctl.dt)
                ctl.command_arm(q, qd)
                q_prev = q
            ctl.physics_step()
        ctl.command_arm(q_prev)
        self.target, self.yaw = p1, yaw1

    def proprio(self) -> NDArray[np.float32]:
        """The measured grasp target (3), yaw, finger opening, arm joints (7)."""
        ctl = self._ctl
        if ctl is None:
            return np.zeros(PROPRIO_SIZE, dtype=np.float32)
        pos, orn = ctl.ee_pose()
        x, y, z, w = (float(v) for v in orn)
        rot = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        fingers = self.world.pb.getJointStates(self.world.panda, list(panda_joints(
            self.world).fingers), physicsClientId=self.world.client)
        opening = float(np.mean([s[0] for s in fingers]))
        out = np.concatenate([pos, [yaw_of(rot), opening], ctl.joint_positions()])
        return out.astype(np.float32)
