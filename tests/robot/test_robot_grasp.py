"""Grasp geometry: gripper footprints, room around them, the hand's yaw, carrying height."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nsrmp_bench.generators.robot.grasp import (
    FINGER_BELOW_GRASP,
    MAX_FINGER_OPENING,
    choose_grasp_yaw,
    clearance,
    finger_opening,
    grasp_height,
    gripper_parts,
    obstacles,
    travel_height,
)
from nsrmp_bench.scene import Pose, SceneObject, yaw_quaternion
from nsrmp_bench.vocabulary import EXTENTS, TABLE_TOP_Z

BASE = (0.0, 0.5, TABLE_TOP_Z)


def on_table(shape: str, x: float, y: float, yaw: float = 0.0) -> Pose:
    return Pose((x, y, TABLE_TOP_Z + EXTENTS[shape][2] / 2.0), yaw_quaternion(yaw))


@pytest.mark.parametrize("shape", ["cube", "dice", "lego"])
def test_fingers_clear_the_object_and_the_table(shape: str) -> None:
    obj = SceneObject(shape, "red")
    pose = on_table(shape, 0.0, 0.0)
    opening = finger_opening(obj)
    assert max(EXTENTS[shape][:2]) / 2.0 < opening <= MAX_FINGER_OPENING
    z = grasp_height(obj, pose)
    assert z - FINGER_BELOW_GRASP > TABLE_TOP_Z  # fingertips above the table
    assert z < pose.position[2] + EXTENTS[shape][2] / 2.0  # below the top face
    # the open fingers do not touch the object they straddle
    own = obstacles([obj], [pose])
    for yaw in (0.0, math.pi / 2.0):
        fingers = gripper_parts((0.0, 0.0), yaw, z, opening)[:2]
        assert clearance(fingers, own) > 0.003


def test_gripper_axis_follows_the_yaw() -> None:
    parts = gripper_parts((0.0, 0.0), 0.0, 0.7, 0.04)
    centres = [p.mean(axis=0) for p, _, _ in parts[:2]]
    assert all(abs(c[0]) < 1e-12 for c in centres)  # yaw 0: fingers close along y
    parts = gripper_parts((0.0, 0.0), math.pi / 2.0, 0.7, 0.04)
    centres = [p.mean(axis=0) for p, _, _ in parts[:2]]
    assert all(abs(c[1]) < 1e-12 for c in centres)  # a quarter turn: along x


def test_clearance_ignores_objects_below_or_above_the_parts() -> None:
    cube = SceneObject("cube", "blue")
    beside = on_table("cube", 0.06, 0.0)
    parts = gripper_parts((0.0, 0.0), math.pi / 2.0, grasp_height(cube, on_table("cube", 0, 0)),
                          0.037)
    assert clearance(parts, obstacles([cube], [beside])) < 0.0  # a finger overlaps it
    high = gripper_parts((0.0, 0.0), math.pi / 2.0, 0.9, 0.037)
    assert clearance(high, obstacles([cube], [beside])) == math.inf


def test_placing_beside_a_tall_stack_turns_the_hand_away_from_it() -> None:
    """Left of a 2-high stack 3 cm away: fingers and hand must close across y, not x."""
    cube = SceneObject("cube", "red")
    objects = [cube, SceneObject("dice", "blue"), SceneObject("cube", "green")]
    stack = [on_table("dice", 0.0, 0.0), Pose((0.0, 0.0, TABLE_TOP_Z + 0.075))]
    target = on_table("cube", -0.08, 0.0)
    pick = on_table("cube", -0.2, -0.15, yaw=0.1)
    state = [pick, *stack]
    others = obstacles(objects, state, exclude=(0,))
    plan = choose_grasp_yaw(cube, pick, target, others, others, BASE,
                            grasp_height(cube, target))
    axis = np.array([math.sin(plan.place_yaw), -math.cos(plan.place_yaw)])
    assert abs(axis[0]) < 0.2  # closing along y: nothing of the hand reaches the stack
    assert plan.clearance_place > 0.01


def test_travel_height_clears_a_stack_on_the_path_but_not_one_far_away() -> None:
    objects = [SceneObject("cube", "red"), SceneObject("cube", "blue")]
    stack = [on_table("cube", 0.0, 0.0), Pose((0.0, 0.0, TABLE_TOP_Z + 0.075))]
    obs = obstacles(objects, stack)
    hang = 0.025
    over = travel_height((-0.2, 0.0), (0.2, 0.0), obs, hang, 0.03)
    assert over == pytest.approx(TABLE_TOP_Z + 0.1 + 0.03 + hang)
    away = travel_height((-0.2, 0.3), (0.2, 0.3), obs, hang, 0.03)
    assert away == pytest.approx(TABLE_TOP_Z + 0.03 + hang)
