"""``export-lerobot`` of a robot split: the Panda's joint positions at 30 Hz as state and
action, read back the way lerobot's ``LeRobotDataset`` reads it (``datasets`` with the
features ``info.json`` declares), frame counts and values equal to the HDF5's. The data is
the first 7 instances of robot-v2/test (six one-step episodes and a two-step one),
generated here."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

datasets = pytest.importorskip("datasets")
pq = pytest.importorskip("pyarrow.parquet")
pytest.importorskip("pybullet")

from nsrmp_bench.cli.main import main  # noqa: E402
from nsrmp_bench.errors import InvalidArgument  # noqa: E402
from nsrmp_bench.export.lerobot_frames import episode_frames  # noqa: E402
from nsrmp_bench.storage import open as open_storage  # noqa: E402
from nsrmp_bench.vocabulary import ACTIONS  # noqa: E402

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def robot_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from nsrmp_bench.generators.generate import generate_split

    out = tmp_path_factory.mktemp("robot-v2")
    generate_split("robot-v2", out, parts=["test"], limit=7, workers=1)
    return out


@pytest.fixture(scope="module")
def exported(robot_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("lerobot-robot") / "robot"
    assert main(["export-lerobot", str(robot_root), "--out", str(out), "--quiet"]) == 0
    return out


def _hf_features(features: dict[str, Any]) -> Any:
    """What lerobot's get_hf_features_from_features makes of info.json's features."""
    out: dict[str, Any] = {}
    for key, ft in features.items():
        if ft["dtype"] == "image":
            out[key] = datasets.Image()
        elif tuple(ft["shape"]) == (1,):
            out[key] = datasets.Value(ft["dtype"])
        else:
            out[key] = datasets.List(datasets.Value(ft["dtype"]), length=ft["shape"][0])
    return datasets.Features(out)


def test_info_states_30_hz_joints(exported: Path, robot_root: Path) -> None:
    info = json.loads((exported / "meta/info.json").read_text())
    assert info["fps"] == 30 and info["robot_type"] == "panda"
    assert info["nsrmp_bench"]["executor"] == "robot"
    with open_storage(robot_root / "test") as collection:
        names = list(collection.episode(0, images=False).rendering.trajectory.joint_names)
    assert len(names) == 9
    assert info["features"]["observation.state"]["names"] == names
    assert info["features"]["action"]["names"] == names
    assert info["features"]["observation.environment_state"]["shape"] == [105]
    stats = json.loads((exported / "meta/stats.json").read_text())
    assert set(stats) == set(info["features"])
    assert all(s["count"] == [info["total_frames"]] for s in stats.values())


def test_frames_read_as_lerobot_reads_them_equal_the_hdf5(exported: Path,
                                                          robot_root: Path) -> None:
    info = json.loads((exported / "meta/info.json").read_text())
    data_file = exported / info["data_path"].format(chunk_index=0, file_index=0)
    frames = datasets.Dataset.from_parquet(str(data_file),
                                           features=_hf_features(info["features"]))
    episodes = pq.read_table(exported / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert len(episodes) == info["total_episodes"] == 7
    multi_step = 0
    with open_storage(robot_root / "test") as collection:
        for e, row in enumerate(episodes):
            ep = collection.episode(e, images=True)
            rend = ep.rendering
            traj = rend.trajectory
            samples = len(traj.time)
            assert row["length"] == samples + 1  # every sample, then the final state
            lo, hi = row["dataset_from_index"], row["dataset_to_index"]
            assert hi - lo == samples + 1
            ep_frames = frames.select(range(lo, hi))
            state = np.asarray(ep_frames["observation.state"], dtype=np.float32)
            joints = traj.joint_positions.astype(np.float32)
            np.testing.assert_array_equal(state[:samples], joints)
            np.testing.assert_array_equal(state[samples], joints[-1])
            action = np.asarray(ep_frames["action"], dtype=np.float32)
            np.testing.assert_array_equal(action[: samples - 1], joints[1:])
            np.testing.assert_array_equal(action[samples - 1:], joints[[-1, -1]])
            np.testing.assert_allclose(ep_frames["timestamp"],
                                       np.arange(samples + 1) / 30, atol=1e-5)
            np.testing.assert_allclose(ep_frames["observation.sample_time"][:samples],
                                       traj.time, atol=1e-5)
            done = ep_frames["next.done"]
            assert done[-1] and not any(done[:-1])
            multi_step += ep.symbolic.num_steps > 1
            n = ep.symbolic.num_objects
            for k in (0, samples // 2, samples - 1, samples):
                f = ep_frames[k]
                s = int(traj.step[k]) if k < samples else ep.symbolic.num_steps
                assert np.array_equal(np.asarray(f["observation.images.rgb"]),
                                      rend.observations.rgb[s])
                env_state = np.asarray(f["observation.environment_state"],
                                       dtype=np.float32).reshape(-1, 7)
                np.testing.assert_array_equal(env_state[:n],
                                              rend.targets.poses[s].astype(np.float32))
                if k < samples:
                    g = ep.symbolic.grounded[s]
                    assert f["action.step"] == [ACTIONS.index(g.action), g.subject,
                                                g.reference]
                else:
                    assert f["action.step"] == [-1, -1, -1]
                    assert f["action.move"] == [0.0, 0.0, 0.0, 0.0]
    assert multi_step >= 1  # the step boundary is covered


def test_a_teleport_episode_in_a_robot_split_is_refused(robot_root: Path,
                                                        smoke_v2_test: Path) -> None:
    with open_storage(smoke_v2_test) as collection:
        teleport = collection.episode(0, images=True)
    with pytest.raises(InvalidArgument, match=r"is a teleport episode in a split whose "
                                              r"first episode is a robot one"):
        episode_frames(teleport, "robot")
