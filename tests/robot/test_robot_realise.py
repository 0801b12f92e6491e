"""Robot-executed episodes: rendered and checked like teleported ones, stored, exported."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from robot_cases import generated

from nsrmp_bench.episode import Episode, SeedInfo, SymbolicEpisode
from nsrmp_bench.generators.robot.realise import RobotPlacer
from nsrmp_bench.generators.world.realise import realise

pytestmark = pytest.mark.sim


def _indexed(ep: SymbolicEpisode, index: int) -> SymbolicEpisode:
    """The episode as instance ``index`` (storage writes instances in index order)."""
    data = ep.to_dict()
    data["seed"] = SeedInfo(ep.seed.entropy, index, ep.seed.attempt).to_dict()
    data["id"] = f"robot-test-{index:06d}"
    return SymbolicEpisode.from_dict(data)


def test_a_robot_realisation_matches_the_teleported_one(world: Any) -> None:
    ep = generated(8, 3, 300, "any")
    robot = realise(ep.scene, ep.states, ep.grounded, world, placer=RobotPlacer())
    teleport = realise(ep.scene, ep.states, ep.grounded, world)
    assert robot.executor == "robot" and teleport.executor == "teleport"
    assert robot.physics["robot"]["success"]
    assert len(robot.physics["robot"]["steps"]) == 3
    # same targets up to what the hand did differently: sub-millimetre to millimetres
    diff = np.abs(robot.targets.poses[..., :3] - teleport.targets.poses[..., :3]).max()
    assert diff < 0.005
    box_diff = np.abs(robot.targets.boxes_amodal - teleport.targets.boxes_amodal).max()
    assert box_diff < 2.0  # pixels
    traj = robot.trajectory
    assert traj is not None and len(traj.time) > 100
    assert set(np.unique(traj.step).tolist()) == {0, 1, 2}
    assert robot.observations is not None
    assert robot.observations.rgb.shape[0] == 4
    # the arm is back at rest for every render: the images equal the teleported ones
    # wherever neither shows an object
    assert teleport.observations is not None
    still = (robot.observations.segmentation < 0) & (teleport.observations.segmentation < 0)
    same = (robot.observations.rgb == teleport.observations.rgb).all(axis=-1)
    assert same[still].mean() > 0.999


def test_robot_episodes_store_their_trajectory_and_export_it(world: Any, tmp_path: Path) -> None:
    from nsrmp_bench.storage import open as open_data
    from nsrmp_bench.storage import write_shard

    episodes = []
    for k, index in enumerate((301, 302)):
        ep = _indexed(generated(5, 2, index), k)
        episodes.append(Episode(ep, realise(ep.scene, ep.states, ep.grounded, world,
                                            placer=RobotPlacer())))
    write_shard(tmp_path, 0, episodes, split="robot-test-v1")
    shard = next(tmp_path.glob("*.h5"))
    coll = open_data(shard)
    back = list(coll.iter_episodes(images=False))
    assert len(back) == 2
    for orig, read in zip(episodes, back, strict=True):
        assert read.rendering is not None and orig.rendering is not None
        assert read.rendering.executor == "robot"
        a, b = orig.rendering.trajectory, read.rendering.trajectory
        assert a is not None and b is not None
        assert np.array_equal(a.joint_positions, b.joint_positions)
        assert np.array_equal(a.ee_pose, b.ee_pose) and np.array_equal(a.step, b.step)
        assert tuple(b.joint_names) == tuple(a.joint_names)
    pytest.importorskip("mcap")
    from mcap.reader import make_reader

    from nsrmp_bench.storage.mcap_export import export_mcap

    out = tmp_path / "robot.mcap"
    export_mcap(shard, out)
    with out.open("rb") as fh:
        topics = {ch.topic for ch in make_reader(fh).get_summary().channels.values()}
    assert any("joint" in t for t in topics), topics
