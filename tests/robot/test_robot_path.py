"""The end effector's recorded path, projected and drawn over an image."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from robot_cases import generated

from nsrmp_bench.generators.replay.episode import stage_scene
from nsrmp_bench.generators.robot.path import draw_ee_path, ee_path_pixels, gripper_events
from nsrmp_bench.generators.robot.pick_and_place import execute_program

pytestmark = pytest.mark.sim


def test_grasp_and_release_are_found_once_per_step_where_they_happened(world: Any) -> None:
    ep = generated(7, 3, 400)
    stage_scene(world, ep.scene)
    image = world.render().rgb
    result = execute_program(world, ep.scene, ep.states, ep.grounded)
    traj = result.trajectory
    closes, opens = gripper_events(traj)
    assert traj.step[closes].tolist() == [0, 1, 2]
    assert traj.step[opens].tolist() == [0, 1, 2]
    assert (closes < opens).all()
    for k, g in enumerate(ep.grounded):
        grasp = traj.ee_pose[closes[k], :3]
        release = traj.ee_pose[opens[k], :3]
        assert np.linalg.norm(grasp[:2] - ep.states[k][g.subject].position[:2]) < 0.005
        assert np.linalg.norm(release[:2] - ep.states[k + 1][g.subject].position[:2]) < 0.005
    uv = ee_path_pixels(world.camera, traj, step=1)
    assert uv.shape == (int((traj.step == 1).sum()), 2)
    drawn = draw_ee_path(image, world.camera, traj)
    assert drawn.shape == image.shape and drawn.dtype == np.uint8
    assert (drawn != image).any(axis=-1).sum() > 200
    one = draw_ee_path(image, world.camera, traj, step=0)
    assert 0 < (one != image).any(axis=-1).sum() < (drawn != image).any(axis=-1).sum()
    big = draw_ee_path(np.repeat(np.repeat(image, 2, axis=0), 2, axis=1), world.camera, traj,
                       scale=2)
    assert big.shape == (2 * image.shape[0], 2 * image.shape[1], 3)
