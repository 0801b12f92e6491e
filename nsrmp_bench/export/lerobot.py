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
``video_path`` is null), encoded by ``datasets``' Image feature as lerobot does. The
frames and features of teleport splits (one frame per rendered state, ``fps`` 1) and of
robot splits (the Panda's joint positions at 30 Hz as state and action) are in
:mod:`nsrmp_bench.export.lerobot_frames`. The task is the instruction. Each split part is
one lerobot ``split`` (``info.json`` ``splits``), episodes in part order.
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
from nsrmp_bench.export.lerobot_frames import (
    FPS,
    IMAGE_KEY,
    episode_frames,
    lerobot_features,
    split_kind,
)
from nsrmp_bench.export.staging import staged_folder

__all__ = ["CODEBASE_VERSION", "export_lerobot", "read_info"]

CODEBASE_VERSION: Final = "v3.0"
DATA_PATH: Final = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
EPISODES_PATH: Final = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
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
    image_feature = require("datasets").Image()
    parts = split_parts(data)
    features: dict[str, dict[str, Any]] | None = None
    kind = "teleport"
    joint_names: tuple[str, ...] = ()
    tasks: dict[str, int] = {}
    episodes_rows: list[dict[str, Any]] = []
    columns: dict[str, list[NDArray[Any]]] = {}
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
                    if features is None:
                        kind = split_kind(ep)
                        joint_names = _joint_names(ep)
                    elif _joint_names(ep) != joint_names:
                        msg = (f"episode {ep.id} names its joints {list(_joint_names(ep))}, "
                               f"earlier episodes {list(joint_names)}; export one robot's "
                               "split at a time")
                        raise InvalidArgument(msg)
                    fr = episode_frames(ep, kind)
                    height, width = fr.images.shape[1:3]
                    if features is None:
                        features = lerobot_features(kind, height, width, joint_names)
                        writer = arrow_writer.ParquetWriter(
                            path=str(data_file), features=_hf_features(features))
                    length = len(fr)
                    task = ep.symbolic.instruction.text
                    task_index = tasks.setdefault(task, len(tasks))
                    cols = {
                        "timestamp": np.arange(length, dtype=np.float32) / FPS[kind],
                        "frame_index": np.arange(length, dtype=np.int64),
                        "episode_index": np.full(length, ep_index, dtype=np.int64),
                        "index": np.arange(index, index + length, dtype=np.int64),
                        "task_index": np.full(length, task_index, dtype=np.int64),
                    }
                    cols.update(fr.columns)
                    # each rendered image PNG-encoded once (as datasets' Image feature
                    # encodes an array), however many frames show it
                    encoded = [image_feature.encode_example(img) for img in fr.images]
                    for k in range(length):
                        assert writer is not None
                        writer.write({IMAGE_KEY: encoded[int(fr.image_of[k])], **{
                            name: (col[k].item() if col.ndim == 1 else col[k])
                            for name, col in cols.items()}})
                    for key, col in cols.items():
                        columns.setdefault(key, []).append(col)
                    shown = np.bincount(fr.image_of, minlength=len(fr.images))
                    for img, times in zip(fr.images, shown, strict=True):
                        if times == 0:
                            continue
                        rgb = img.reshape(-1, 3).astype(np.float64)
                        img_sum += times * rgb.sum(axis=0)
                        img_sq += times * (rgb**2).sum(axis=0)
                        img_lo = np.minimum(img_lo, rgb.min(axis=0))
                        img_hi = np.maximum(img_hi, rgb.max(axis=0))
                        pixels += int(times) * rgb.shape[0]
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
        stats = {IMAGE_KEY: _image_stats(img_sum, img_sq, img_lo, img_hi, pixels, index),
                 **{k: _stats(cat[k]) for k in features if k != IMAGE_KEY}}
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
            "fps": FPS[kind],
            "splits": splits,
            "data_path": DATA_PATH,
            "video_path": None,
            "features": features,
            "nsrmp_bench": {"split": parts[0].split, "executor": kind, "frames": (
                "one per rendered state" if kind == "teleport" else
                "one per 30 Hz robot sample, then one on the final state")},
        }
        (meta / "info.json").write_text(json.dumps(info, indent=4) + "\n", "utf-8")
        (meta / "stats.json").write_text(json.dumps(stats, indent=4) + "\n", "utf-8")
    return info


def _joint_names(episode: Episode) -> tuple[str, ...]:
    r = episode.rendering
    if r is None or r.trajectory is None:
        return ()
    traj = r.trajectory
    return traj.joint_names or tuple(f"joint{j}" for j in range(traj.joint_positions.shape[1]))


def read_info(root: str | os.PathLike[str]) -> dict[str, Any]:
    """``meta/info.json`` of an exported folder."""
    info: dict[str, Any] = json.loads((Path(root) / "meta" / "info.json").read_text("utf-8"))
    return info
