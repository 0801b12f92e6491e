"""``export-hf``: a split as Hugging Face ``datasets`` Parquet shards with a dataset card.

Layout (one folder, ready to upload to the Hub as a dataset repository)::

    OUT/README.md                      dataset card; YAML ``configs`` name the split and
                                       map each part to a datasets split
    OUT/<part>/<shard>.parquet         one Parquet file per HDF5 shard, written by
                                       datasets' own ParquetWriter (features embedded)

One row per episode. Images are ``Image`` features (PNG); depth and segmentation are
``Array2D`` per rendered state; boxes, poses and the per-object targets are nested lists
``(states, objects, k)``; ``symbolic`` is the episode's symbolic record as canonical JSON
(``SymbolicEpisode.to_dict``), so every field of the HDF5 episode is in the row.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from nsrmp_bench._optional import require
from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.export.episodes import PartData, split_parts
from nsrmp_bench.export.staging import staged_folder

if TYPE_CHECKING:
    import datasets

    from nsrmp_bench.storage.manifest import Manifest
    from nsrmp_bench.storage.reader import EpisodeCollection

__all__ = ["export_hf", "hf_features", "hf_split_name"]


def hf_split_name(part: str) -> str:
    """The datasets split name of ``part`` (datasets allows letters, digits, ``_``, ``.``)."""
    return part.replace("-", "_")


def hf_features(height: int, width: int) -> Any:
    """The ``datasets.Features`` of one episode row."""
    ds = require("datasets")
    f32, f64, i32 = ds.Value("float32"), ds.Value("float64"), ds.Value("int32")
    per_object = ds.List(ds.List(ds.List(f32)))
    return ds.Features({
        "id": ds.Value("string"),
        "split": ds.Value("string"),
        "instruction": ds.Value("string"),
        "template_id": ds.Value("string"),
        "phrasing": ds.Value("string"),
        "num_steps": i32,
        "num_objects": i32,
        "objects": ds.List({"shape": ds.Value("string"), "colour": ds.Value("string")}),
        "program": ds.List({"action": ds.Value("string"), "subject": i32,
                            "reference": i32}),
        "symbolic": ds.Value("string"),
        "camera": ds.Value("string"),
        "intrinsics": ds.List(ds.List(f64)),
        "extrinsics": ds.List(ds.List(f64)),
        "executor": ds.Value("string"),
        "rgb": ds.List(ds.Image()),
        "depth": ds.List(ds.Array2D((height, width), "float32")),
        "segmentation": ds.List(ds.Array2D((height, width), "int16")),
        "poses": ds.List(ds.List(ds.List(f64))),
        "boxes_amodal": per_object,
        "boxes_visible": per_object,
        "visible_fraction": ds.List(ds.List(f32)),
        "depth_centre": ds.List(ds.List(f32)),
    })


def episode_row(episode: Episode, split: str) -> dict[str, Any]:
    """One row of the export (plain Python values and arrays)."""
    sym = episode.symbolic
    rendering = episode.rendering
    if rendering is None or rendering.observations is None:
        msg = (f"episode {episode.id} has no rendered images; export-hf needs a rendered "
               "split (generate it with images)")
        raise InvalidArgument(msg)
    obs = rendering.observations
    tg = rendering.targets
    cam = rendering.camera
    return {
        "id": sym.id,
        "split": split,
        "instruction": sym.instruction.text,
        "template_id": sym.instruction.template_id,
        "phrasing": sym.instruction.phrasing,
        "num_steps": sym.num_steps,
        "num_objects": sym.num_objects,
        "objects": [o.to_dict() for o in sym.scene.objects],
        "program": [{"action": s.action, "subject": s.subject, "reference": s.reference}
                    for s in sym.grounded],
        "symbolic": json.dumps(sym.to_dict(), sort_keys=True, separators=(",", ":")),
        "camera": json.dumps(cam.to_dict(), sort_keys=True, separators=(",", ":")),
        "intrinsics": np.asarray(cam.intrinsics).tolist(),
        "extrinsics": np.asarray(cam.extrinsics).tolist(),
        "executor": rendering.executor,
        "rgb": list(np.asarray(obs.rgb)),
        "depth": list(np.asarray(obs.depth, dtype=np.float32)),
        "segmentation": list(np.asarray(obs.segmentation, dtype=np.int16)),
        "poses": np.asarray(tg.poses).tolist(),
        "boxes_amodal": np.asarray(tg.boxes_amodal).tolist(),
        "boxes_visible": np.asarray(tg.boxes_visible).tolist(),
        "visible_fraction": np.asarray(tg.visible_fraction).tolist(),
        "depth_centre": np.asarray(tg.depth_centre).tolist(),
    }


def _card(split: str, parts: list[PartData], features: datasets.Features) -> str:
    lines = [
        "---",
        "license: mit",
        "task_categories:",
        "- robotics",
        "tags:",
        "- nsrmp-bench",
        "- manipulation",
        "- language-conditioned",
        f"pretty_name: nsrmp-bench {split}",
        "configs:",
        f"- config_name: {split}",
        "  default: true",
        "  data_files:",
    ]
    for p in parts:
        lines += [f"  - split: {hf_split_name(p.part)}", f"    path: {p.part}/*.parquet"]
    lines += ["---", "", f"# nsrmp-bench {split}", "",
              "Language-guided tabletop manipulation episodes (instruction, grounded program, "
              "RGB, depth and segmentation per rendered state, per-object poses and amodal "
              "boxes), exported from the HDF5 release by `nsrmp-bench export-hf`.", "",
              "| part | datasets split | episodes |", "|---|---|---|"]
    lines += [f"| {p.part} | {hf_split_name(p.part)} | {p.count} |" for p in parts]
    lines += ["", "## Load", "", "```python", "from datasets import load_dataset",
              f'ds = load_dataset("USER/REPO", "{split}", split="{hf_split_name(parts[0].part)}",'
              ' revision="COMMIT_SHA")',
              "```", "", "## Fields", "", "| field | type |", "|---|---|"]
    lines += [f"| `{k}` | `{type(v).__name__}` |" for k, v in features.items()]
    lines += ["", "Units: metres, quaternions xyzw, boxes pixel xyxy, depth float32 metres; "
              "segmentation holds object indices (-1: table, robot, background). "
              "`symbolic` is the episode's symbolic record as JSON.", ""]
    return "\n".join(lines)


def export_hf(data: str | os.PathLike[str], out: str | os.PathLike[str], *,
              progress: Callable[[int], None] | None = None) -> list[Path]:
    """Export the split under ``data`` into ``out`` (new or empty); the Parquet files."""
    arrow_writer = require("datasets.arrow_writer")
    parts = split_parts(data)
    split = parts[0].split
    written: list[Path] = []
    done = 0
    with staged_folder(out) as tmp:
        features = None
        for part in parts:
            from nsrmp_bench.storage import open as open_storage

            with open_storage(part.path) as collection:
                manifest = _manifest(collection)
                (tmp / part.part).mkdir()
                for shard in manifest.shards:
                    name = Path(shard.file).name.split(".")[0] + ".parquet"
                    path = tmp / part.part / name
                    writer = None
                    try:
                        for entry in shard.episodes:
                            ep = collection.get(entry.id, images=True)
                            if features is None:
                                cam = ep.rendering.camera if ep.rendering else None
                                if cam is None:
                                    episode_row(ep, "")  # raises the clear error
                                    raise AssertionError
                                features = hf_features(cam.height, cam.width)
                            if writer is None:
                                writer = arrow_writer.ParquetWriter(path=str(path),
                                                                    features=features)
                            writer.write(episode_row(ep, f"{split}/{part.part}"))
                            done += 1
                            if progress is not None:
                                progress(done)
                    finally:
                        if writer is not None:
                            writer.finalize()
                            writer.close()
                    written.append(Path(out) / part.part / name)
        if features is None:
            msg = f"{data} holds no episode; generate the split first"
            raise InvalidArgument(msg)
        (tmp / "README.md").write_text(_card(split, parts, features), "utf-8")
    return written


def _manifest(collection: EpisodeCollection) -> Manifest:
    """The part's manifest (a part directory always has one)."""
    if collection.manifest is None:
        msg = f"{collection.root} is a single shard; give its part directory (with manifest.json)"
        raise InvalidArgument(msg)
    return collection.manifest
