"""``export-lerobot``: a split in the LeRobot dataset v3.0 layout, written with pyarrow.

lerobot itself is not a dependency (its releases pin a torch older than ours and import
torchvision, which does not load against this torch), so the layout lerobot documents
for ``codebase_version`` ``v3.0`` is written here::

    OUT/meta/info.json                           features, fps, counts, path templates
    OUT/meta/stats.json                          min/max/mean/std/count per feature
    OUT/meta/tasks.parquet                       task (index) -> task_index
    OUT/meta/episodes/chunk-000/file-000.parquet one row per episode: length, tasks,
                                                 dataset_from_index/to_index, file indices
    OUT/data/chunk-000/file-000.parquet          one row per frame, images embedded

Images are ``image`` features stored in the data Parquet (the layout's non-video mode;
``video_path`` is null), encoded by ``datasets``' Image feature as lerobot does.
One frame per rendered state (teleport semantics, ``fps`` 1): ``observation.state`` is
every object's pose (position xyz + quaternion xyzw, scene order, zero rows past the
last object, 15 x 7), ``action`` the move made from that state as image points
(pick u, v = the moved object's box centre before, place u, v = after; zeros on the
last frame), ``action.step`` the DSL step (action index, subject, reference; -1 on the
last frame), ``next.done`` true on the last frame. The task is the instruction. Each
split part is one lerobot ``split`` (``info.json`` ``splits``), episodes in part order.
The robot's joint trajectories of robot parts are not exported (see the README).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require
from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.export.episodes import split_parts
from nsrmp_bench.export.staging import staged_folder
from nsrmp_bench.geometry.boxes import box_centres
from nsrmp_bench.vocabulary import ACTIONS, MAX_OBJECTS

__all__ = ["CODEBASE_VERSION", "export_lerobot", "lerobot_features"]

CODEBASE_VERSION: Final = "v3.0"
FPS: Final = 1
DATA_PATH: Final = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
EPISODES_PATH: Final = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
IMAGE_KEY: Final = "observation.images.rgb"
_POSE = ("x", "y", "z", "qx", "qy", "qz", "qw")


def lerobot_features(height: int, width: int) -> dict[str, dict[str, Any]]:
    """The ``features`` block of ``info.json``."""
    return {
        IMAGE_KEY: {"dtype": "image", "shape": [height, width, 3],
                    "names": ["height", "width", "channels"]},
        "observation.state": {
            "dtype": "float32", "shape": [MAX_OBJECTS * 7],
            "names": [f"object{i}.{c}" for i in range(MAX_OBJECTS) for c in _POSE]},
        "action": {"dtype": "float32", "shape": [4],
                   "names": ["pick_u", "pick_v", "place_u", "place_v"]},
        "action.step": {"dtype": "int64", "shape": [3],
                        "names": ["action", "subject", "reference"]},
        "next.done": {"dtype": "bool", "shape": [1], "names": None},
        "timestamp": {"dtype": "float32", "shape": [1], "names": None},
        "frame_index": {"dtype": "int64", "shape": [1], "names": None},
        "episode_index": {"dtype": "int64", "shape": [1], "names": None},
        "index": {"dtype": "int64", "shape": [1], "names": None},
        "task_index": {"dtype": "int64", "shape": [1], "names": None},
    }


def _hf_features(features: dict[str, dict[str, Any]]) -> Any:
    """The ``datasets.Features`` lerobot derives from ``info.json`` features."""
    ds = require("datasets")
    out: dict[str, Any] = {}
    for key, ft in features.items():
        if ft["dtype"] == "image":
            out[key] = ds.Image()
        elif list(ft["shape"]) == [1]:
            out[key] = ds.Value(ft["dtype"])
        else:
            out[key] = ds.List(ds.Value(ft["dtype"]), length=ft["shape"][0])
    return ds.Features(out)


def episode_frames(episode: Episode) -> dict[str, Any]:
    """Per-frame columns of one episode (without the global indices)."""
    rendering = episode.rendering
    if rendering is None or rendering.observations is None:
        msg = (f"episode {episode.id} has no rendered images; export-lerobot needs a "
               "rendered split")
        raise InvalidArgument(msg)
    sym = episode.symbolic
    poses = np.asarray(rendering.targets.poses, dtype=np.float32)  # (S+1, N, 7)
    boxes = np.asarray(rendering.targets.boxes_amodal, dtype=np.float64)
    frames = poses.shape[0]
    n = poses.shape[1]
    state = np.zeros((frames, MAX_OBJECTS * 7), dtype=np.float32)
    state[:, : n * 7] = poses.reshape(frames, n * 7)
    action = np.zeros((frames, 4), dtype=np.float32)
    step = np.full((frames, 3), -1, dtype=np.int64)
    for k, g in enumerate(sym.grounded):
        action[k, :2] = box_centres(boxes[k, g.subject])
        action[k, 2:] = box_centres(boxes[k + 1, g.subject])
        step[k] = (ACTIONS.index(g.action), g.subject, g.reference)
    done = np.zeros(frames, dtype=bool)
    done[-1] = True
    return {"rgb": np.asarray(rendering.observations.rgb), "state": state,
            "action": action, "step": step, "done": done}


def _stats(values: NDArray[Any]) -> dict[str, Any]:
    v = np.asarray(values, dtype=np.float64)
    if v.ndim == 1:
        v = v[:, None]
    return {"min": v.min(axis=0).tolist(), "max": v.max(axis=0).tolist(),
            "mean": v.mean(axis=0).tolist(), "std": v.std(axis=0).tolist(),
            "count": [int(v.shape[0])]}


def _image_stats(sums: NDArray[np.float64], squares: NDArray[np.float64],
                 lo: NDArray[np.float64], hi: NDArray[np.float64], pixels: int,
                 frames: int) -> dict[str, Any]:
    mean = sums / pixels
    std = np.sqrt(np.maximum(squares / pixels - mean**2, 0.0))

    def chw(x: NDArray[np.float64]) -> list[Any]:
        out: list[Any] = (x / 255.0).reshape(3, 1, 1).tolist()
        return out

    return {"min": chw(lo), "max": chw(hi), "mean": chw(mean), "std": chw(std),
            "count": [frames]}


def export_lerobot(data: str | os.PathLike[str], out: str | os.PathLike[str], *,
                   progress: Callable[[int], None] | None = None) -> dict[str, Any]:
    """Export the split under ``data`` to ``out`` (new or empty); returns ``info.json``."""
    pa = require("pyarrow")
    pq = require("pyarrow.parquet")
    arrow_writer = require("datasets.arrow_writer")
    parts = split_parts(data)
    features: dict[str, dict[str, Any]] | None = None
    tasks: dict[str, int] = {}
    episodes_rows: list[dict[str, Any]] = []
    columns: dict[str, list[NDArray[Any]]] = {
        k: [] for k in ("state", "action", "step", "done", "timestamp", "frame_index",
                        "episode_index", "index", "task_index")}
    img_sum = np.zeros(3)
    img_sq = np.zeros(3)
    img_lo = np.full(3, 255.0)
    img_hi = np.zeros(3)
    pixels = 0
    splits: dict[str, str] = {}
    index = 0
    ep_index = 0
    with staged_folder(out) as tmp:
        data_file = tmp / DATA_PATH.format(chunk_index=0, file_index=0)
        data_file.parent.mkdir(parents=True)
        writer = None
        try:
            for part in parts:
                first = ep_index
                for ep in part.episodes(images=True):
                    fr = episode_frames(ep)
                    height, width = fr["rgb"].shape[1:3]
                    if features is None:
                        features = lerobot_features(height, width)
                        writer = arrow_writer.ParquetWriter(
                            path=str(data_file), features=_hf_features(features))
                    length = len(fr["done"])
                    task = ep.symbolic.instruction.text
                    task_index = tasks.setdefault(task, len(tasks))
                    cols = {
                        "timestamp": np.arange(length, dtype=np.float32) / FPS,
                        "frame_index": np.arange(length, dtype=np.int64),
                        "episode_index": np.full(length, ep_index, dtype=np.int64),
                        "index": np.arange(index, index + length, dtype=np.int64),
                        "task_index": np.full(length, task_index, dtype=np.int64),
                    }
                    for k in range(length):
                        assert writer is not None
                        writer.write({
                            IMAGE_KEY: fr["rgb"][k],
                            "observation.state": fr["state"][k],
                            "action": fr["action"][k],
                            "action.step": fr["step"][k],
                            "next.done": bool(fr["done"][k]),
                            **{name: col[k].item() for name, col in cols.items()},
                        })
                    for key in ("state", "action", "step", "done"):
                        columns[key].append(fr[key])
                    for key, col in cols.items():
                        columns[key].append(col)
                    rgb = fr["rgb"].reshape(-1, 3).astype(np.float64)
                    img_sum += rgb.sum(axis=0)
                    img_sq += (rgb**2).sum(axis=0)
                    img_lo = np.minimum(img_lo, rgb.min(axis=0))
                    img_hi = np.maximum(img_hi, rgb.max(axis=0))
                    pixels += rgb.shape[0]
                    episodes_rows.append({
                        "episode_index": ep_index, "tasks": [task], "length": length,
                        "data/chunk_index": 0, "data/file_index": 0,
                        "dataset_from_index": index, "dataset_to_index": index + length,
                        "meta/episodes/chunk_index": 0, "meta/episodes/file_index": 0,
                        "nsrmp_bench/id": ep.id,
                    })
                    index += length
                    ep_index += 1
                    if progress is not None:
                        progress(ep_index)
                splits[part.part] = f"{first}:{ep_index}"
        finally:
            if writer is not None:
                writer.finalize()
                writer.close()
        if features is None:
            msg = f"{data} holds no episode; generate the split first"
            raise InvalidArgument(msg)
        cat = {k: np.concatenate(v) for k, v in columns.items()}
        stats = {
            IMAGE_KEY: _image_stats(img_sum, img_sq, img_lo, img_hi, pixels, index),
            "observation.state": _stats(cat["state"]),
            "action": _stats(cat["action"]),
            "action.step": _stats(cat["step"]),
            "next.done": _stats(cat["done"].astype(np.float64)),
            **{k: _stats(cat[k]) for k in ("timestamp", "frame_index", "episode_index",
                                           "index", "task_index")},
        }
        meta = tmp / "meta"
        (meta / "episodes" / "chunk-000").mkdir(parents=True)
        pq.write_table(pa.Table.from_pylist(episodes_rows),
                       tmp / EPISODES_PATH.format(chunk_index=0, file_index=0))
        pd = require("pandas")
        task_frame = pd.DataFrame({"task_index": np.arange(len(tasks), dtype=np.int64)},
                                  index=pd.Index(list(tasks), name="task"))
        task_frame.to_parquet(meta / "tasks.parquet")
        info = {
            "codebase_version": CODEBASE_VERSION,
            "robot_type": "panda",
            "total_episodes": ep_index,
            "total_frames": index,
            "total_tasks": len(tasks),
            "chunks_size": 1000,
            "data_files_size_in_mb": 100,
            "video_files_size_in_mb": 500,
            "fps": FPS,
            "splits": splits,
            "data_path": DATA_PATH,
            "video_path": None,
            "features": features,
            "nsrmp_bench": {"split": parts[0].split, "frames": "one per rendered state"},
        }
        (meta / "info.json").write_text(json.dumps(info, indent=4) + "\n", "utf-8")
        (meta / "stats.json").write_text(json.dumps(stats, indent=4) + "\n", "utf-8")
    return info


def read_info(root: str | os.PathLike[str]) -> dict[str, Any]:
    """``meta/info.json`` of an exported folder."""
    info: dict[str, Any] = json.loads((Path(root) / "meta" / "info.json").read_text("utf-8"))
    return info
