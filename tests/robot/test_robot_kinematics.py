"""The numpy kinematics reproduce PyBullet's arm and reach the whole target area."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")

from nsrmp_bench.generators.robot.control import (
    READY,
    arm_kinematics,
    panda_joints,
    posture,
)
from nsrmp_bench.generators.robot.grasp import neutral_yaw
from nsrmp_bench.generators.robot.kinematics import down_rotation
from nsrmp_bench.generators.world.world import PANDA_BASE
from nsrmp_bench.vocabulary import TABLE_TOP_Z, TARGET_AREA

pytestmark = pytest.mark.sim


def _pybullet_pose(world: Any, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    pb, c, body = world.pb, world.client, world.panda
    joints = panda_joints(world)
    saved = pb.getJointStates(body, list(joints.arm), physicsClientId=c)
    for j, v in zip(joints.arm, q, strict=True):
        pb.resetJointState(body, j, float(v), physicsClientId=c)
    ls = pb.getLinkState(body, joints.ee, computeForwardKinematics=1, physicsClientId=c)
    for j, s in zip(joints.arm, saved, strict=True):
        pb.resetJointState(body, j, s[0], s[1], physicsClientId=c)
    rot = np.array(pb.getMatrixFromQuaternion(ls[5])).reshape(3, 3)
    return np.asarray(ls[4]), rot


def test_forward_kinematics_matches_pybullet(world: Any) -> None:
    kin = arm_kinematics(world, panda_joints(world))
    rng = np.random.default_rng(7)
    for _ in range(10):
        q = rng.uniform(kin.lower, kin.upper)
        p, r, _, _ = kin.fk(q)
        p_pb, r_pb = _pybullet_pose(world, q)
        assert np.abs(p - p_pb).max() < 1e-6
        assert np.abs(r - r_pb).max() < 1e-6


@pytest.mark.parametrize("x", [TARGET_AREA.x_min, 0.0, TARGET_AREA.x_max])
@pytest.mark.parametrize("y", [TARGET_AREA.y_min, 0.0, TARGET_AREA.y_max])
def test_inverse_kinematics_reaches_the_target_area_within_limits(world: Any, x: float,
                                                                   y: float) -> None:
    kin = arm_kinematics(world, panda_joints(world))
    for z in (TABLE_TOP_Z + 0.02, TABLE_TOP_Z + 0.15):
        yaw = neutral_yaw(x, y, PANDA_BASE)
        for turn in (-math.pi / 2.0, 0.0, math.pi / 2.0):
            res = kin.ik((x, y, z), down_rotation(yaw + turn), READY, posture((x, y, z), yaw))
            assert (res.q >= kin.lower).all() and (res.q <= kin.upper).all()
            p, r, _, _ = kin.fk(res.q)
            assert res.position_error == pytest.approx(float(np.linalg.norm(p - (x, y, z))))
            # the far front corners are at the edge of reach: allow 2 mm there
            assert res.position_error < 2e-3
            assert r[2, 2] < -0.998  # pointing down (within 3.6 degrees at the reach limit)
