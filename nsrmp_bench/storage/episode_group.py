"""One episode as an HDF5 group of a shard: its arrays, attributes and image chunks.

Every writer compresses the image chunks itself with Python's ``zlib`` and stores them
with ``write_direct_chunk`` (:mod:`~nsrmp_bench.storage.chunks`): the filters HDF5 would
apply (byte shuffle for float images, then DEFLATE level 1), so the same bytes on disk.
An RGB or segmentation image is compressed after the rows it shares with the shard's
background, resuming a copy of the background's compressor
(:mod:`~nsrmp_bench.storage.prefix_deflate`): the same bytes.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.episode import Episode
from nsrmp_bench.storage import h5_objects
from nsrmp_bench.storage.arrays import episode_arrays
from nsrmp_bench.storage.chunks import (
    Compressed,
    filtered_chunk,
    has_filtered_chunks,
    image_chunks,
    image_datasets,
)
from nsrmp_bench.storage.layout import check_episode_id, small_codec
from nsrmp_bench.storage.prefix_deflate import PrefixDeflater

__all__ = ["write_episode_group"]


def _put_image(group: h5py.h5g.GroupID, path: str, name: str, arr: NDArray[Any],
               kw: Mapping[str, Any], compressed: Compressed,
               deflater: PrefixDeflater | None) -> None:
    """An :func:`image_codec` dataset, its chunks compressed here (or taken from
    ``compressed``) and written as they are: the filters HDF5 would apply, so the same
    bytes. ``path`` is the group's path in the episode group."""
    key = f"{path}/{name}"
    if not has_filtered_chunks(kw):  # an empty stack
        h5_objects.dataset(group, name, arr, kw)
        return
    chunks = list(image_chunks(arr, kw))  # refuses other chunk shapes before creating
    ds = h5_objects.empty_dataset(group, name, arr.shape, arr.dtype, kw)
    for k, offset, chunk in chunks:
        ready = compressed.get((key, k))
        ds.write_direct_chunk(offset, ready if ready is not None
                              else filtered_chunk(chunk, kw, deflater))


def write_episode_group(parent: h5py.Group, episode: Episode, index: int, ehash: str, *,
                        compressed: Compressed | None = None,
                        deflater: PrefixDeflater | None = None) -> None:
    """Write one episode as ``parent/<id>`` in the layout of :mod:`~nsrmp_bench.storage.layout`.

    The groups, datasets and attributes are made through :mod:`~nsrmp_bench.storage.
    h5_objects` (h5py's low-level calls, the same bytes as its high-level ones).
    The image chunks are compressed here by Python's zlib (:func:`~nsrmp_bench.storage.
    chunks.filtered_chunk`) and written with ``write_direct_chunk``, not by HDF5's filters
    called through h5py: the same bytes, less CPU (h5py's filter path copies and converts
    on the way), and zlib lets go of the GIL, so a writer thread leaves its caller room.
    ``compressed`` holds chunks already through the filters (:func:`~nsrmp_bench.storage.
    chunks.precompress`), stored as they are. A ``deflater`` (one per shard) compresses
    the rest, resuming after the rows they share with the shard's learnt background (the
    same bytes; :mod:`~nsrmp_bench.storage.prefix_deflate`)."""
    if deflater is not None:
        deflater.next_episode()
    sym = episode.symbolic
    arrays = episode_arrays(episode)
    g = h5_objects.group(parent.id, check_episode_id(sym.id))
    put = h5_objects.attribute
    put(g, "id", sym.id)
    put(g, "index", np.int64(index))
    put(g, "content_hash", ehash)
    put(g, "num_steps", np.int64(sym.num_steps))
    put(g, "num_objects", np.int64(sym.num_objects))
    put(g, "seed", canonical_json(sym.seed.to_dict()))
    put(g, "generator", sym.generator)
    r = episode.rendering
    put(g, "has_rendering", np.bool_(r is not None))
    put(g, "has_images", np.bool_("observations/rgb" in arrays))
    if r is not None:
        put(g, "camera", canonical_json(r.camera.to_dict()))
        put(g, "executor", r.executor)
        # a dataset, not an attribute: robot executors can record more than 64 KiB
        h5_objects.string_dataset(g, "physics", canonical_json(r.physics))

    inputs = h5_objects.group(g, "inputs")
    h5_objects.string_dataset(inputs, "instruction", sym.instruction.text)
    targets = h5_objects.group(g, "targets")
    h5_objects.string_dataset(targets, "symbolic", canonical_json(sym.to_dict()))
    h5_objects.string_dataset(targets, "program", sym.program.text())

    images = image_datasets(arrays)
    if images:
        groups = {"inputs/obs": h5_objects.group(inputs, "obs"),
                  "targets/obs": h5_objects.group(targets, "obs")}
        for path, name, arr, kw in images:
            _put_image(groups[path], path, name, arr, kw, compressed or {}, deflater)
    if r is not None:
        for key in ("boxes_amodal", "boxes_visible"):
            h5_objects.dataset(inputs, key, arrays[f"targets/{key}"][0], small_codec())
        for key in ("poses", "boxes_amodal", "boxes_visible", "visible_fraction",
                    "depth_centre"):
            h5_objects.dataset(targets, key, arrays[f"targets/{key}"], small_codec())
        if r.trajectory is not None:
            robot = h5_objects.group(targets, "robot")
            put(robot, "joint_names", canonical_json(list(r.trajectory.joint_names)))
            for key in ("time", "joint_positions", "ee_pose", "gripper", "step"):
                h5_objects.dataset(robot, key, arrays[f"trajectory/{key}"], small_codec())
