"""Forward and inverse kinematics of the Panda arm in numpy, built from the loaded URDF.

PyBullet's own IK comes in two kinds, and neither serves a long pick-and-place: the plain
solver is accurate but, started from the arm's state every time, drifts along the arm's
redundancy until joints 1 and 3 twist against each other around a straight shoulder
(joint 2 near 0, a singularity) where it stalls centimetres short; the null-space solver
does not converge to millimetres. This solver is damped least squares on the full pose
with a weak null-space pull towards a comfortable posture, clamped to the joint limits,
iterated until the grasp target is within a tenth of a millimetre.

The kinematic chain (joint frames, axes, the fixed hand and grasp-target offsets) is read
from the PyBullet body once, so it is exactly the simulated arm's.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Final

import numpy as np
from numpy.typing import NDArray

__all__ = ["IKResult", "PandaKinematics", "down_rotation"]

F64 = NDArray[np.float64]
Vec = Sequence[float] | NDArray[np.float64]

_ROT_WEIGHT: Final = 0.15  # m per rad: how much an orientation error counts
_DAMPING: Final = 0.02
_NULL_GAIN: Final = 0.15
_LIMIT_MARGIN: Final = 0.02  # rad kept away from each joint limit
_POS_TOL: Final = 5e-5  # m
_ROT_TOL: Final = 2e-3  # rad


def _cross_rows(a: F64, b: F64) -> F64:
    """Row-wise cross products of ``(n, 3)`` arrays (np.cross is slow on small arrays)."""
    out = np.empty_like(a)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def _null_direction(jac: F64) -> F64:
    """Unit vector spanning the null space of a full-rank 6x7 Jacobian."""
    sq = jac[:, :6]
    if abs(float(np.linalg.det(sq))) > 1e-9:
        v = np.empty(7)
        v[:6] = -np.linalg.solve(sq, jac[:, 6])
        v[6] = 1.0
        out: F64 = v / float(np.linalg.norm(v))
        return out
    null: F64 = np.linalg.svd(jac)[2][-1]
    return null


def _quat_matrix(q: Vec) -> F64:
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _transform(pos: Vec, orn: Vec) -> F64:
    t = np.eye(4)
    t[:3, :3] = _quat_matrix(orn)
    t[:3, 3] = pos
    return t


def _axis_rotation(axis: F64, angle: float) -> F64:
    """4x4 rotation by ``angle`` about the unit ``axis`` (Rodrigues)."""
    k = axis
    c, s = math.cos(angle), math.sin(angle)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    t = np.eye(4)
    t[:3, :3] = np.eye(3) + s * kx + (1.0 - c) * (kx @ kx)
    return t


def down_rotation(yaw: float) -> F64:
    """The hand's rotation when pointing straight down with ``yaw``: Euler (pi, 0, yaw)."""
    c, s = math.cos(yaw), math.sin(yaw)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    rx = np.diag([1.0, -1.0, -1.0])
    out: F64 = rz @ rx
    return out


@dataclass(frozen=True)
class IKResult:
    """Joint positions, the remaining position (m) and orientation (rad) error, and the
    number of solver updates made."""

    q: F64
    position_error: float
    rotation_error: float
    iterations: int


class PandaKinematics:
    """The arm's chain from the world to the grasp target, for numpy FK and IK."""

    def __init__(self, pb: ModuleType, client: int, body: int, arm: Sequence[int], ee: int) -> None:
        c = client
        base_pos, base_orn = pb.getBasePositionAndOrientation(body, physicsClientId=c)
        base_inertia = pb.getDynamicsInfo(body, -1, physicsClientId=c)
        # PyBullet reports the base's centre of mass; the URDF frame sits before its offset.
        com = _transform(base_inertia[3], base_inertia[4])
        self.base = _transform(base_pos, base_orn) @ np.linalg.inv(com)
        self.arm = tuple(arm)
        self.lower = np.array([pb.getJointInfo(body, j, physicsClientId=c)[8] for j in arm])
        self.upper = np.array([pb.getJointInfo(body, j, physicsClientId=c)[9] for j in arm])
        self._fixed: list[F64] = []
        # PyBullet 3.2.x reports a joint's parent-frame orientation inverted; try that
        # reading first, and the literal one if the chain does not match the simulation.
        for conjugate in (True, False):
            self._fixed = self._chain(pb, c, body, ee, conjugate)
            if self.check(pb, c, body, ee) < 1e-6:
                return
        msg = (
            "the Panda's kinematic chain read from PyBullet does not reproduce its link "
            f"poses (error {self.check(pb, c, body, ee):.3g} m); this PyBullet version "
            "reports joint frames differently: use pybullet 3.2.x"
        )
        raise RuntimeError(msg)

    def _chain(self, pb: ModuleType, c: int, body: int, ee: int, conjugate: bool) -> list[F64]:
        """Fixed transforms before, between and after the arm's joint rotations."""
        links: list[int] = []
        j = ee
        while j >= 0:
            links.append(j)
            j = int(pb.getJointInfo(body, j, physicsClientId=c)[16])
        fixed_between: list[F64] = []
        acc = self.base.copy()
        for link in reversed(links):
            info = pb.getJointInfo(body, link, physicsClientId=c)
            # A joint frame is given in its parent's centre-of-mass frame.
            parent_com = pb.getDynamicsInfo(body, int(info[16]), physicsClientId=c)
            ox, oy, oz, ow = info[15]
            orn = (-ox, -oy, -oz, ow) if conjugate else (ox, oy, oz, ow)
            acc = acc @ _transform(parent_com[3], parent_com[4]) @ _transform(info[14], orn)
            if link in self.arm:
                axis = np.asarray(info[13], dtype=np.float64)
                if float(np.abs(axis - np.array([0.0, 0.0, 1.0])).max()) > 1e-9:
                    msg = f"arm joint axis {axis.tolist()} is not +z; unsupported URDF"
                    raise ValueError(msg)
                fixed_between.append(acc)
                acc = np.eye(4)
        fixed_between.append(acc)
        if len(fixed_between) != len(self.arm) + 1:
            msg = f"the chain to link {ee} does not pass through all arm joints {list(self.arm)}"
            raise ValueError(msg)
        return fixed_between

    def fk(self, q: Vec) -> tuple[F64, F64, F64, F64]:
        """Grasp-target position (3,), rotation (3, 3), joint origins (7, 3), axes (7, 3)."""
        n = len(self.arm)
        origins = np.empty((n, 3))
        axes = np.empty((n, 3))
        t = self._fixed[0]
        rz = np.eye(4)
        for k in range(n):
            origins[k] = t[:3, 3]
            axes[k] = t[:3, 2]
            c, s = math.cos(q[k]), math.sin(q[k])
            rz[0, 0] = c
            rz[0, 1] = -s
            rz[1, 0] = s
            rz[1, 1] = c
            t = t @ rz @ self._fixed[k + 1]
        return t[:3, 3].copy(), t[:3, :3].copy(), origins, axes

    def check(self, pb: ModuleType, client: int, body: int, ee: int) -> float:
        """Largest FK error (m) against PyBullet at the body's current joint positions."""
        states = pb.getJointStates(body, list(self.arm), physicsClientId=client)
        p, _, _, _ = self.fk([s[0] for s in states])
        ls = pb.getLinkState(body, ee, computeForwardKinematics=1, physicsClientId=client)
        return float(np.abs(p - np.asarray(ls[4])).max())

    def ik(
        self,
        position: Vec,
        rotation: F64,
        q0: Vec,
        posture: Vec | None = None,
        max_iterations: int = 30,
    ) -> IKResult:
        """Joints putting the grasp target at ``position`` with ``rotation``, from ``q0``.

        ``posture`` (if given) is pulled towards in the null space of the task.
        """
        target = np.asarray(position, dtype=np.float64)
        q = np.clip(np.asarray(q0, dtype=np.float64), self.lower + _LIMIT_MARGIN,
                    self.upper - _LIMIT_MARGIN)
        rest = None if posture is None else np.asarray(posture, dtype=np.float64)
        n = len(q)
        eye6 = np.eye(6)
        e_pos = e_rot = math.inf
        used = 0
        while True:
            p, r, origins, axes = self.fk(q)
            dp = target - p
            dr = 0.5 * _cross_rows(r.T, rotation.T).sum(axis=0)
            e_pos = float(np.linalg.norm(dp))
            e_rot = float(np.linalg.norm(dr))
            if (e_pos < _POS_TOL and e_rot < _ROT_TOL) or used >= max_iterations:
                break
            used += 1
            jac = np.empty((6, n))
            jac[:3] = _cross_rows(axes, p - origins).T
            jac[3:] = _ROT_WEIGHT * axes.T
            err = np.concatenate([dp, _ROT_WEIGHT * dr])
            dq = jac.T @ np.linalg.solve(jac @ jac.T + (_DAMPING**2) * eye6, err)
            if rest is not None:  # the arm's one redundant direction: the task's null space
                null = _null_direction(jac)
                dq += float(null @ (rest - q)) * _NULL_GAIN * null
            q = np.clip(q + dq, self.lower + _LIMIT_MARGIN, self.upper - _LIMIT_MARGIN)
        return IKResult(q, e_pos, e_rot, used)
