"""``export-lerobot``: the LeRobot dataset v3.0 layout, checked file by file against the
layout lerobot documents (``meta/info.json``, ``meta/stats.json``, ``meta/tasks.parquet``,
``meta/episodes/chunk-000/file-000.parquet``, ``data/chunk-000/file-000.parquet``) and
read back the way lerobot's ``LeRobotDataset`` reads it (``datasets`` with the features
``info.json`` declares), values equal to the HDF5's. lerobot itself is not installed here:
its releases pin torch < 2.11 and import torchvision."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

datasets = pytest.importorskip("datasets")
pq = pytest.importorskip("pyarrow.parquet")

from nsrmp_bench.cli.main import main  # noqa: E402
from nsrmp_bench.errors import InvalidArgument  # noqa: E402
from nsrmp_bench.storage import open as open_storage  # noqa: E402
from nsrmp_bench.vocabulary import ACTIONS  # noqa: E402

# lerobot's v3.0 constants (lerobot/datasets/utils.py)
INFO_KEYS = {"codebase_version", "robot_type", "total_episodes", "total_frames",
             "total_tasks", "chunks_size", "data_files_size_in_mb",
             "video_files_size_in_mb", "fps", "splits", "data_path", "video_path",
             "features"}
DEFAULT_FEATURES = {"timestamp": "float32", "frame_index": "int64", "episode_index": "int64",
                    "index": "int64", "task_index": "int64"}
EPISODE_COLUMNS = {"episode_index", "tasks", "length", "data/chunk_index", "data/file_index",
                   "dataset_from_index", "dataset_to_index", "meta/episodes/chunk_index",
                   "meta/episodes/file_index"}


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


@pytest.fixture(scope="module")
def exported(smoke_v2_root: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("lerobot") / "smoke"
    assert main(["export-lerobot", str(smoke_v2_root), "--out", str(out), "--quiet"]) == 0
    return out


def test_layout_files_and_info(exported: Path) -> None:
    files = sorted(p.relative_to(exported).as_posix() for p in exported.rglob("*")
                   if p.is_file())
    assert files == ["data/chunk-000/file-000.parquet", "meta/episodes/chunk-000/file-000.parquet",
                     "meta/info.json", "meta/stats.json", "meta/tasks.parquet"]
    info = json.loads((exported / "meta/info.json").read_text())
    assert set(info) >= INFO_KEYS
    assert info["codebase_version"] == "v3.0"
    assert info["data_path"] == "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    assert info["video_path"] is None
    for key, dtype in DEFAULT_FEATURES.items():
        assert info["features"][key]["dtype"] == dtype
        assert info["features"][key]["shape"] == [1]
    assert all("/" not in k for k in info["features"])  # lerobot refuses '/' in names
    assert info["splits"] == {"test": "0:16"}
    assert isinstance(info["fps"], int)


def test_data_read_as_lerobot_reads_it_equals_the_hdf5(exported: Path,
                                                       smoke_v2_root: Path) -> None:
    info = json.loads((exported / "meta/info.json").read_text())
    data_file = exported / info["data_path"].format(chunk_index=0, file_index=0)
    frames = datasets.Dataset.from_parquet(str(data_file),
                                           features=_hf_features(info["features"]))
    assert len(frames) == info["total_frames"]
    episodes = pq.read_table(exported / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert set(episodes[0]) >= EPISODE_COLUMNS
    assert len(episodes) == info["total_episodes"] == 16
    tasks = pq.read_table(exported / "meta/tasks.parquet").to_pandas()
    assert tasks.index.name == "task" and list(tasks.columns) == ["task_index"]
    assert len(tasks) == info["total_tasks"]
    with open_storage(smoke_v2_root / "test") as collection:
        for e, row in enumerate(episodes):
            ep = collection.episode(e, images=True)
            rend = ep.rendering
            assert rend is not None and rend.observations is not None
            n_states = rend.observations.rgb.shape[0]
            assert row["episode_index"] == e and row["length"] == n_states
            assert row["tasks"] == [ep.symbolic.instruction.text]
            assert tasks.loc[ep.symbolic.instruction.text, "task_index"] >= 0
            lo, hi = row["dataset_from_index"], row["dataset_to_index"]
            assert hi - lo == n_states
            n = ep.symbolic.num_objects
            for k in range(n_states):
                f = frames[lo + k]
                assert (f["episode_index"], f["frame_index"], f["index"]) == (e, k, lo + k)
                assert f["timestamp"] == pytest.approx(k / info["fps"])
                assert f["task_index"] == int(tasks.loc[ep.symbolic.instruction.text,
                                                        "task_index"])
                assert np.array_equal(np.asarray(f["observation.images.rgb"]),
                                      rend.observations.rgb[k])
                state = np.asarray(f["observation.state"], dtype=np.float32).reshape(-1, 7)
                np.testing.assert_array_equal(state[:n], rend.targets.poses[k].astype(np.float32))
                assert not state[n:].any()
                assert f["next.done"] == (k == n_states - 1)
                if k < ep.symbolic.num_steps:
                    g = ep.symbolic.grounded[k]
                    assert f["action.step"] == [ACTIONS.index(g.action), g.subject, g.reference]
                else:
                    assert f["action.step"] == [-1, -1, -1]


def test_stats_cover_every_feature(exported: Path) -> None:
    info = json.loads((exported / "meta/info.json").read_text())
    stats = json.loads((exported / "meta/stats.json").read_text())
    assert set(stats) == set(info["features"])
    for key, s in stats.items():
        assert {"min", "max", "mean", "std", "count"} <= set(s), key
        assert s["count"] == [info["total_frames"]]
    assert np.asarray(stats["observation.images.rgb"]["mean"]).shape == (3, 1, 1)
    assert len(stats["observation.state"]["mean"]) == info["features"]["observation.state"]["shape"][0]


def test_a_non_empty_target_is_refused(smoke_v2_root: Path, tmp_path: Path) -> None:
    from nsrmp_bench.export.lerobot import export_lerobot

    (tmp_path / "meta").mkdir()
    with pytest.raises(InvalidArgument, match=r"is not empty.*meta"):
        export_lerobot(smoke_v2_root, tmp_path)
    with pytest.raises(InvalidArgument, match="not a folder"):
        export_lerobot(tmp_path / "nothing", tmp_path / "x")
