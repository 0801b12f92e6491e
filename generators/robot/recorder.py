"""Recording the Panda's motion at a fixed rate into :class:`~nsrmp_bench.episode.Trajectory`.

A :class:`TrajectoryRecorder` samples every ``every``-th physics step: the positions of the
arm and finger joints, the pose of the grasp target (the point between the fingertips)
and the gripper opening (sum of both finger positions). Trajectories of consecutive steps
are joined with :func:`concatenate_trajectories`.
"""

from __future__ import annotations

from collections.abc import Sequence
from types import ModuleType

import numpy as np

from nsrmp_bench.episode import Trajectory

__all__ = ["TrajectoryRecorder", "concatenate_trajectories", "empty_trajectory"]


class TrajectoryRecorder:
    """Samples joint positions, end-effector pose and gripper opening of one body."""

    def __init__(
        self,
        pb: ModuleType,
        client: int,
        body: int,
        joints: Sequence[int],
        fingers: Sequence[int],
        ee_link: int,
        joint_names: Sequence[str],
        every: int,
        dt: float,
        t0: float = 0.0,
    ) -> None:
        self._pb = pb
        self._client = client
        self._body = body
        self._joints = list(joints) + list(fingers)
        self._n_fingers = len(fingers)
        self._ee = ee_link
        self.joint_names = tuple(joint_names)
        self.every = max(1, int(every))
        self.dt = dt
        self.t0 = t0
        self.steps = 0  # physics steps seen
        self.step_index = 0  # program step being executed
        self._time: list[float] = []
        self._q: list[list[float]] = []
        self._ee_pose: list[list[float]] = []
        self._grip: list[float] = []
        self._step: list[int] = []

    def sample(self) -> None:
        """Record the current state now (at the current simulated time)."""
        pb, c = self._pb, self._client
        states = pb.getJointStates(self._body, self._joints, physicsClientId=c)
        q = [float(s[0]) for s in states]
        ls = pb.getLinkState(self._body, self._ee, computeForwardKinematics=1,
                             physicsClientId=c)
        self._time.append(self.t0 + self.steps * self.dt)
        self._q.append(q)
        self._ee_pose.append([*ls[4], *ls[5]])
        self._grip.append(sum(q[len(q) - self._n_fingers:]))
        self._step.append(self.step_index)

    def tick(self) -> None:
        """Count one physics step; sample if it falls on the recording rate."""
        self.steps += 1
        if self.steps % self.every == 0:
            self.sample()

    @property
    def time(self) -> float:
        """Simulated time now (seconds since the recording's origin)."""
        return self.t0 + self.steps * self.dt

    def trajectory(self) -> Trajectory:
        """What was recorded so far."""
        n = len(self._time)
        nj = len(self._joints)
        return Trajectory(
            time=np.asarray(self._time, dtype=np.float64).reshape(n),
            joint_positions=np.asarray(self._q, dtype=np.float64).reshape(n, nj),
            ee_pose=np.asarray(self._ee_pose, dtype=np.float64).reshape(n, 7),
            gripper=np.asarray(self._grip, dtype=np.float64).reshape(n),
            step=np.asarray(self._step, dtype=np.int16).reshape(n),
            joint_names=self.joint_names,
        )


def empty_trajectory(joint_names: Sequence[str] = ()) -> Trajectory:
    """A trajectory with no samples."""
    nj = len(joint_names)
    return Trajectory(
        time=np.zeros(0, dtype=np.float64),
        joint_positions=np.zeros((0, nj), dtype=np.float64),
        ee_pose=np.zeros((0, 7), dtype=np.float64),
        gripper=np.zeros(0, dtype=np.float64),
        step=np.zeros(0, dtype=np.int16),
        joint_names=tuple(joint_names),
    )


def concatenate_trajectories(parts: Sequence[Trajectory]) -> Trajectory:
    """The samples of ``parts`` one after the other (their times are kept as they are)."""
    if not parts:
        return empty_trajectory()
    names = parts[0].joint_names
    return Trajectory(
        time=np.concatenate([p.time for p in parts]),
        joint_positions=np.concatenate([p.joint_positions for p in parts]),
        ee_pose=np.concatenate([p.ee_pose for p in parts]),
        gripper=np.concatenate([p.gripper for p in parts]),
        step=np.concatenate([p.step for p in parts]).astype(np.int16),
        joint_names=names,
    )
