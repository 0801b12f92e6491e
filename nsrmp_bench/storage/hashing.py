"""Content hashes of episodes and of whole splits.

``episode_hash`` is the sha256 of, in order:

1. the tag ``nsrmp-episode-hash-v1`` and a newline;
2. the canonical JSON of the symbolic episode (``SymbolicEpisode.to_dict()``) and a newline;
3. the canonical JSON of the rendering's metadata (camera defining fields, executor,
   physics, joint names; ``null`` without a rendering) and a newline;
4. for every array present (see :data:`~nsrmp_bench.storage.layout.ARRAY_SPECS` for the
   order), a header line ``name dtype shape`` (dtype as numpy's ``str``, e.g. ``<f4``;
   shape comma-separated) followed by the array's C-order little-endian bytes.

So the hash does not depend on the storage layout, codec or shard; an episode read without
its images cannot be re-hashed (its ``observations/*`` are absent).

``root_hash`` is the content hash (sha256 of canonical JSON) of the list of
``[index, episode_hash]`` pairs in index order: independent of shard size and worker count.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from typing import Any

import numpy as np

from nsrmp_bench.canonical import canonical_json, content_hash
from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.arrays import episode_arrays
from nsrmp_bench.storage.layout import ARRAY_SPECS

__all__ = ["HASH_TAG", "camera_fields", "episode_hash", "rendering_meta", "root_hash"]

HASH_TAG = "nsrmp-episode-hash-v1"

_DERIVED_CAMERA_FIELDS = ("intrinsics", "extrinsics_world_to_camera", "convention")


def camera_fields(camera_dict: dict[str, Any]) -> dict[str, Any]:
    """A camera dict without its derived fields (those may differ in the last float bit)."""
    return {k: v for k, v in camera_dict.items() if k not in _DERIVED_CAMERA_FIELDS}


def rendering_meta(episode: Episode) -> dict[str, Any] | None:
    """The non-array part of a rendering, as hashed."""
    r = episode.rendering
    if r is None:
        return None
    try:
        canonical_json(r.physics)
    except (TypeError, ValueError) as exc:
        msg = (
            f"episode {episode.id}: rendering.physics must be strict JSON (str, int, float, "
            f"bool, None, lists and dicts; no NaN or numpy scalars), but {exc}; convert it "
            "with float()/int()/.tolist() and write None for unknown values"
        )
        raise InvalidArgument(msg) from exc
    return {
        "camera": camera_fields(r.camera.to_dict()),
        "executor": r.executor,
        "physics": r.physics,
        "joint_names": list(r.trajectory.joint_names) if r.trajectory is not None else None,
    }


def episode_hash(episode: Episode) -> str:
    """The hex sha256 content hash of an episode (symbolic part plus every array)."""
    digest = hashlib.sha256()
    digest.update(f"{HASH_TAG}\n".encode())
    digest.update(canonical_json(episode.symbolic.to_dict()).encode("utf-8") + b"\n")
    digest.update(canonical_json(rendering_meta(episode)).encode("utf-8") + b"\n")
    arrays = episode_arrays(episode)
    for spec in ARRAY_SPECS:
        arr = arrays.get(spec.name)
        if arr is None:
            continue
        shape = ",".join(str(s) for s in arr.shape)
        digest.update(f"{spec.name} {arr.dtype.str} {shape}\n".encode())
        if arr.size:
            digest.update(arr.reshape(-1).view(np.uint8).data)
    return digest.hexdigest()


def root_hash(entries: Iterable[tuple[int, str]]) -> str:
    """The root hash over ``(index, episode_hash)`` pairs, taken in index order."""
    pairs = sorted((int(i), str(h)) for i, h in entries)
    return content_hash([[i, h] for i, h in pairs])
