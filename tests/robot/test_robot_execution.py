"""The Panda carries out generated programs: success, trajectories, determinism, settings."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from robot_cases import generated

from nsrmp_bench.errors import InvalidArgument, UnknownId
from nsrmp_bench.generators.replay.episode import stage_scene
from nsrmp_bench.generators.robot.pick_and_place import (
    SUCCESS,
    execute_program,
    execute_step,
    robot_joint_names,
)
from nsrmp_bench.generators.robot.profiles import PROFILES
from nsrmp_bench.generators.world.realise import realise
from nsrmp_bench.scene import Pose

pytestmark = pytest.mark.sim

# (objects, steps, index, relational): small and crowded scenes, stacks, left/right moves
CASES = [(5, 3, 0, "any"), (12, 2, 1, "none"), (8, 2, 2, "needed"), (15, 1, 3, "none")]


@pytest.mark.parametrize(("objects", "steps", "index", "relational"), CASES)
def test_generated_instances_succeed(world: Any, objects: int, steps: int, index: int,
                                     relational: str) -> None:
    ep = generated(objects, steps, index, relational)
    stage_scene(world, ep.scene)
    result = execute_program(world, ep.scene, ep.states, ep.grounded, "fast")
    assert len(result.steps) == steps
    for k, step in enumerate(result.steps):
        assert step.success, (k, step.problem, step.to_dict())
        assert step.subject == ep.grounded[k].subject
        assert step.error_m < SUCCESS.position_m
        assert step.symbolic_error_m < SUCCESS.position_m
        assert step.tilt_deg < SUCCESS.tilt_deg
        assert step.disturbed_m < SUCCESS.disturbed_m
    final = result.final_poses
    gold = np.array([p.position for p in ep.states[-1]])
    assert np.abs(final[:, :3] - gold).max() < SUCCESS.position_m
    assert result.success
    summary = result.summary()
    assert summary["executor"] == "robot-v1" and len(summary["steps"]) == steps


def test_trajectory_is_recorded_at_a_fixed_rate(world: Any) -> None:
    ep = generated(6, 2, 4)
    stage_scene(world, ep.scene)
    result = execute_program(world, ep.scene, ep.states, ep.grounded, "fast")
    traj = result.trajectory
    t = traj.time
    n = len(t)
    assert n > 50
    assert traj.joint_positions.shape == (n, 9)
    assert traj.ee_pose.shape == (n, 7) and traj.gripper.shape == (n,)
    assert traj.step.dtype == np.int16 and traj.step.shape == (n,)
    assert traj.joint_names == robot_joint_names(world)
    assert len(traj.joint_names) == 9 and traj.joint_names[-1].startswith("panda_finger")
    dt = np.diff(t)
    assert (dt > 0).all()
    period = 1.0 / PROFILES["fast"].record_hz
    assert np.median(dt) == pytest.approx(period, rel=0.05)
    assert np.allclose(np.linalg.norm(traj.ee_pose[:, 3:], axis=1), 1.0, atol=1e-6)
    assert traj.gripper.min() >= -1e-3 and traj.gripper.max() <= 0.08 + 1e-3
    assert np.allclose(traj.gripper, traj.joint_positions[:, 7:].sum(axis=1))
    assert list(np.unique(traj.step)) == [0, 1]
    assert (np.diff(traj.step) >= 0).all()
    # the hand went down to each subject and each target: its lowest points are near them
    for k, g in enumerate(ep.grounded):
        ee = traj.ee_pose[traj.step == k, :3]
        start = np.asarray(ep.states[k][g.subject].position)
        end = np.asarray(ep.states[k + 1][g.subject].position)
        assert np.linalg.norm(ee - start, axis=1).min() < 0.01
        assert np.linalg.norm(ee - end, axis=1).min() < 0.01
    # the recorded time covers the simulated time of the moves
    assert t[-1] <= result.physics["sim_time"] + 1e-9


def test_robot_ends_close_to_the_teleported_result(world: Any) -> None:
    """Robot-vs-teleport final-pose difference: millimetres, for every object."""
    ep = generated(9, 3, 5, "any")
    teleport = realise(ep.scene, ep.states, ep.grounded, world, render=False)
    stage_scene(world, ep.scene)
    robot = execute_program(world, ep.scene, ep.states, ep.grounded, "fast")
    diff = np.linalg.norm(robot.final_poses[:, :3] - teleport.targets.poses[-1][:, :3], axis=1)
    moved = sorted({g.subject for g in ep.grounded})
    others = [i for i in range(len(ep.scene)) if i not in moved]
    assert diff[moved].max() < 0.005
    assert diff[others].max() < 0.002


def test_the_same_program_twice_gives_identical_results(world: Any) -> None:
    ep = generated(7, 2, 6)
    runs = []
    for _ in range(2):
        stage_scene(world, ep.scene)
        runs.append(execute_program(world, ep.scene, ep.states, ep.grounded, "fast"))
    a, b = runs
    assert np.array_equal(a.final_poses, b.final_poses)
    assert np.array_equal(a.trajectory.joint_positions, b.trajectory.joint_positions)
    assert np.array_equal(a.trajectory.time, b.trajectory.time)


def test_a_session_leaves_the_world_as_it_found_it(world: Any) -> None:
    pb, c = world.pb, world.client
    fingers = [j for j in range(pb.getNumJoints(world.panda, physicsClientId=c))
               if "finger" in pb.getJointInfo(world.panda, j, physicsClientId=c)[1].decode()]
    friction = [pb.getDynamicsInfo(world.panda, f, physicsClientId=c)[1] for f in fingers]
    ep = generated(4, 1, 7)
    stage_scene(world, ep.scene)
    execute_program(world, ep.scene, ep.states, ep.grounded, "fast")
    assert pb.getNumConstraints(physicsClientId=c) == 0
    params = pb.getPhysicsEngineParameters(physicsClientId=c)
    assert params["fixedTimeStep"] == pytest.approx(world.config.time_step)
    assert params["numSolverIterations"] == world.config.solver_iterations
    assert [pb.getDynamicsInfo(world.panda, f, physicsClientId=c)[1] for f in fingers] == friction
    # and a teleported instance afterwards is bit-identical to one in a fresh world
    from nsrmp_bench.generators.world.world import World

    other = generated(6, 2, 8)
    after_robot = realise(other.scene, other.states, other.grounded, world, render=False)
    with World() as fresh:
        baseline = realise(other.scene, other.states, other.grounded, fresh, render=False)
    assert np.array_equal(after_robot.targets.poses, baseline.targets.poses)


def test_realistic_profile_takes_longer_and_succeeds(world: Any) -> None:
    ep = generated(5, 1, 9)
    stage_scene(world, ep.scene)
    fast = execute_program(world, ep.scene, ep.states, ep.grounded, "fast")
    stage_scene(world, ep.scene)
    slow = execute_program(world, ep.scene, ep.states, ep.grounded, "realistic")
    assert fast.success and slow.success
    assert slow.physics["sim_time"] > 2.0 * fast.physics["sim_time"]
    assert np.abs(slow.final_poses[:, :3] - fast.final_poses[:, :3]).max() < 0.005


def test_execute_step_to_a_free_spot_reports_the_error(world: Any) -> None:
    ep = generated(3, 1, 10)
    stage_scene(world, ep.scene)
    subject = 0
    p = ep.scene.initial[subject]
    x = -0.25 if p.position[0] > 0 else 0.25
    target = Pose((x, -0.15, p.position[2]), p.orientation)
    result = execute_step(world, subject, target, "fast", symbolic_target=target)
    assert result.success, result.to_dict()
    assert result.error_m == pytest.approx(math.dist(result.achieved.position, target.position))
    assert result.symbolic_error_m == pytest.approx(result.error_m)
    turned = abs(math.remainder(result.achieved.yaw - target.yaw, 2 * math.pi))
    assert turned < math.radians(2)  # the object keeps its yaw


def test_bad_arguments_are_refused_with_a_fix(world: Any) -> None:
    ep = generated(3, 1, 11)
    stage_scene(world, ep.scene)
    with pytest.raises(InvalidArgument, match=r"out of range.*objects 0\.\.2"):
        execute_step(world, 7, ep.scene.initial[0])
    with pytest.raises(UnknownId, match=r"unknown motion profile 'slow'.*fast"):
        execute_step(world, 0, ep.scene.initial[1], "slow")
    other = generated(4, 1, 12)
    with pytest.raises(InvalidArgument, match=r"World\.begin"):
        execute_program(world, other.scene, other.states, other.grounded)
    with pytest.raises(InvalidArgument, match=r"steps\+1 states"):
        execute_program(world, ep.scene, ep.states[:1], ep.grounded)


def test_a_world_without_a_panda_is_refused() -> None:
    from nsrmp_bench.generators.world.world import World, WorldConfig

    ep = generated(3, 1, 13)
    with World(config=WorldConfig(panda="none")) as bare:
        stage_scene(bare, ep.scene)
        with pytest.raises(InvalidArgument, match="panda='lean'"):
            execute_program(bare, ep.scene, ep.states, ep.grounded)
