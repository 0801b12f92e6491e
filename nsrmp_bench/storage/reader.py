"""Reading shards: a lazy, indexable collection of episodes.

``open(path)`` takes a shard file or a directory with ``manifest.json``. Nothing is read
beyond the index until an episode is asked for; HDF5 handles are opened on first use in
each process (checked by pid), so a collection can be handed to DataLoader workers.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, overload

import h5py
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nsrmp_bench.episode import (
    Episode,
    ObjectTargets,
    Observations,
    Rendering,
    SymbolicEpisode,
    Trajectory,
)
from nsrmp_bench.errors import DataIntegrityError, InvalidArgument, UnknownId
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.storage.hashing import episode_hash
from nsrmp_bench.storage.layout import FORMAT, SHARD_SUFFIX, check_schema_version
from nsrmp_bench.storage.manifest import MANIFEST_NAME, Manifest, read_manifest
from nsrmp_bench.storage.records import CATEGORY_KEYS, OPTIONAL_CATEGORY_KEYS
from nsrmp_bench.storage.split_root import resolve_part
from nsrmp_bench.storage.verified_files import sha256_once

__all__ = ["EpisodeCollection", "input_camera", "open", "read_episode", "read_inputs",
           "read_targets"]

INDEX_COLUMNS = ("id", "split", "index", *CATEGORY_KEYS, "shard")
_MAX_OPEN = 16


@lru_cache(maxsize=64)
def _camera(text: str) -> Camera:
    return Camera.from_dict(json.loads(text))


def _str(ds: h5py.Dataset) -> str:
    return str(ds.asstr()[()])


def _stack(g: h5py.Group, key: str, states: int) -> NDArray[Any]:
    """States 0..S of an input/target image pair: ``inputs/obs/<key>`` + ``targets/obs/<key>``."""
    first = g[f"inputs/obs/{key}"]
    out = np.empty((states, *first.shape), dtype=first.dtype)
    first.read_direct(out, dest_sel=np.s_[0])
    if states > 1:
        g[f"targets/obs/{key}"].read_direct(out, dest_sel=np.s_[1:])
    return out


def read_episode(g: h5py.Group, *, images: bool = True) -> Episode:
    """The :class:`Episode` stored in group ``g`` (``/data/<id>``).

    Without ``images`` the rendering keeps its targets and trajectory but has
    ``observations=None``; this is what scoring reads.
    """
    tg = g["targets"]
    symbolic = SymbolicEpisode.from_dict(json.loads(_str(tg["symbolic"])))
    if not bool(g.attrs["has_rendering"]):
        return Episode(symbolic, None)
    states = symbolic.num_steps + 1
    observations = None
    if images and bool(g.attrs["has_images"]):
        observations = Observations(
            rgb=_stack(g, "rgb", states),
            depth=_stack(g, "depth", states),
            segmentation=g["targets/obs/segmentation"][()],
        )
    targets = ObjectTargets(
        poses=tg["poses"][()],
        boxes_amodal=tg["boxes_amodal"][()],
        boxes_visible=tg["boxes_visible"][()],
        visible_fraction=tg["visible_fraction"][()],
        depth_centre=tg["depth_centre"][()],
    )
    trajectory = None
    if "robot" in tg:
        rb = tg["robot"]
        trajectory = Trajectory(
            time=rb["time"][()],
            joint_positions=rb["joint_positions"][()],
            ee_pose=rb["ee_pose"][()],
            gripper=rb["gripper"][()],
            step=rb["step"][()],
            joint_names=tuple(json.loads(str(rb.attrs["joint_names"]))),
        )
    rendering = Rendering(
        camera=_camera(str(g.attrs["camera"])),
        observations=observations,
        targets=targets,
        executor=str(g.attrs["executor"]),
        trajectory=trajectory,
        physics=json.loads(_str(g["physics"])),
    )
    return Episode(symbolic, rendering)


def read_inputs(g: h5py.Group, *, images: bool = True, visible: bool = True
                ) -> dict[str, Any]:
    """What a model may read: instruction, initial RGB/depth, initial boxes and the camera.

    Keys: ``id``, ``instruction``, ``rgb`` (H, W, 3) uint8, ``depth`` (H, W) float32 metres,
    ``boxes`` (N, 4) amodal pixel xyxy, ``camera`` (a :class:`Camera`), ``boxes_visible``
    (N, 4) (left out unless ``visible``); image, box and camera entries are None when the
    episode has none (:func:`input_camera` reads the camera or says why there is none).
    """
    inp = g["inputs"]
    has_obs = images and "obs" in inp
    has_boxes = "boxes_amodal" in inp
    out = {
        "id": str(g.attrs["id"]),
        "instruction": _str(inp["instruction"]),
        "rgb": inp["obs/rgb"][()] if has_obs else None,
        "depth": inp["obs/depth"][()] if has_obs else None,
        "boxes": inp["boxes_amodal"][()] if has_boxes else None,
        "camera": _camera(str(g.attrs["camera"])) if "camera" in g.attrs else None,
    }
    if visible:
        out["boxes_visible"] = inp["boxes_visible"][()] if has_boxes else None
    return out


def input_camera(inputs: Mapping[str, Any], episode_id: object) -> Camera:
    """The camera of one episode's inputs (:func:`read_inputs`, or the ``inputs`` of an
    ``EpisodeDataset`` item); an episode stored without rendering has none, which is an
    error naming ``episode_id``."""
    camera = inputs.get("camera")
    if isinstance(camera, Camera):
        return camera
    msg = (f"episode {episode_id!r} has no camera (got {camera!r}): it was stored without "
           "rendering, and a learned model reads the initial image, boxes and camera; "
           "generate the split with rendering")
    raise InvalidArgument(msg)


TARGET_ARRAYS = ("poses", "boxes", "boxes_visible", "visible_fraction", "depth_centre")
"""The per-state target arrays :func:`read_targets` reads unless told otherwise."""
_TARGET_DATASETS = {"poses": "poses", "boxes": "boxes_amodal", "boxes_visible": "boxes_visible",
                    "visible_fraction": "visible_fraction", "depth_centre": "depth_centre",
                    "rgb": "obs/rgb"}


def read_targets(g: h5py.Group, arrays: Sequence[str] = TARGET_ARRAYS) -> dict[str, Any]:
    """The gold of an episode: symbolic episode (dict), program text and per-state arrays.

    ``arrays`` picks among ``poses``, ``boxes`` (amodal), ``boxes_visible``,
    ``visible_fraction``, ``depth_centre`` (states 0..S) and ``rgb`` (the render after
    each step, (S, H, W, 3) uint8; read only when asked for); each is None for an episode
    without rendering (``rgb`` also for one stored without images).
    """
    tg = g["targets"]
    out: dict[str, Any] = {
        "id": str(g.attrs["id"]),
        "symbolic": json.loads(_str(tg["symbolic"])),
        "program": _str(tg["program"]),
    }
    for key in arrays:
        if key not in _TARGET_DATASETS:
            msg = f"unknown target array {key!r}; expected some of {list(_TARGET_DATASETS)}"
            raise InvalidArgument(msg)
        name = _TARGET_DATASETS[key]
        out[key] = tg[name][()] if name in tg else None
    return out


@dataclass(frozen=True)
class _Row:
    id: str
    index: int
    shard: str
    hash: str | None
    categories: dict[str, Any]


def _check_root(f: h5py.File, where: str) -> None:
    fmt = f.attrs.get("format")
    if fmt != FORMAT:
        msg = (
            f"{where}: root attribute format is {fmt!r}, expected {FORMAT!r}; this file was "
            "not written by nsrmp-bench (or is damaged)"
        )
        raise DataIntegrityError(msg)
    check_schema_version(f.attrs.get("schema_version"), where)


def _open_h5(path: Path) -> h5py.File:
    try:
        return h5py.File(path, "r")
    except FileNotFoundError as exc:
        msg = f"shard {path} does not exist; re-download or regenerate the data"
        raise DataIntegrityError(msg) from exc
    except OSError as exc:
        msg = (
            f"shard {path} cannot be opened as HDF5 ({exc}); it is truncated or corrupt: "
            "delete it and re-download or regenerate it (a '.tmp' file is an unfinished write)"
        )
        raise DataIntegrityError(msg) from exc


class EpisodeCollection:
    """A lazy, indexable collection of episodes over one or more shards.

    ``len(c)``, ``c[i]`` (position ``i``, negative allowed; slices give lists),
    ``c.get(id)``, iteration (with images), :meth:`iter_episodes` (without images by
    default: the fast path for scoring), :attr:`index` (a pandas DataFrame).
    """

    def __init__(
        self,
        root: Path,
        rows: list[_Row],
        *,
        split: str,
        manifest: Manifest | None = None,
        verify: bool = False,
    ) -> None:
        self.root = root
        self.split = split
        self.manifest = manifest
        self.verify = verify
        self._rows = rows
        self._pos = {r.id: i for i, r in enumerate(rows)}
        self._handles: dict[str, h5py.File] = {}
        self._checked: set[str] = set()
        self._pid = os.getpid()
        self._index: pd.DataFrame | None = None

    # -- files ------------------------------------------------------------------------
    def _path(self, shard: str) -> Path:
        return self.root / shard if self.root.is_dir() else self.root

    def _file(self, shard: str) -> h5py.File:
        if self._pid != os.getpid():  # forked: never use the parent's handles
            self._handles = {}
            self._pid = os.getpid()
        f = self._handles.get(shard)
        if f is not None:
            return f
        if len(self._handles) >= _MAX_OPEN:
            oldest = next(iter(self._handles))
            self._handles.pop(oldest).close()
        path = self._path(shard)
        f = _open_h5(path)
        if shard not in self._checked:
            try:
                _check_root(f, str(path))
            except Exception:
                f.close()
                raise
            self._checked.add(shard)
        self._handles[shard] = f
        return f

    def _group(self, pos: int) -> tuple[h5py.Group, _Row]:
        row = self._rows[pos]
        f = self._file(row.shard)
        try:
            g = f["data"][row.id]
        except (KeyError, OSError) as exc:
            msg = (
                f"episode {row.id} is missing from shard {self._path(row.shard)} ({exc}); "
                "the shard does not match its manifest: re-download or regenerate it"
            )
            raise DataIntegrityError(msg) from exc
        if row.hash is not None and str(g.attrs.get("content_hash")) != row.hash:
            msg = (
                f"episode {row.id} in {self._path(row.shard)} has content hash "
                f"{g.attrs.get('content_hash')}, but the manifest says {row.hash}; the shard "
                "was replaced or modified: re-download or regenerate it"
            )
            raise DataIntegrityError(msg)
        return g, row

    def close(self) -> None:
        """Close every open file (they reopen on the next read)."""
        for f in self._handles.values():
            f.close()
        self._handles = {}

    def __enter__(self) -> EpisodeCollection:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_handles"] = {}
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._pid = os.getpid()

    # -- access -----------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self._rows)

    def _position(self, i: int) -> int:
        n = len(self._rows)
        if not -n <= i < n:
            msg = f"episode position {i} is out of range for a collection of {n} episodes"
            raise IndexError(msg)
        return i % n

    @property
    def inputs_only(self) -> bool:
        """Whether the part holds no gold (``pack --inputs-only``): only its inputs read."""
        if self.manifest is not None:
            return self.manifest.inputs_only
        row = self._rows[0] if self._rows else None
        return row is not None and bool(self._file(row.shard).attrs.get("inputs_only", False))

    def _no_gold(self) -> InvalidArgument:
        return InvalidArgument(
            f"{self.root} is an inputs-only part of {self.split} (packed without its gold): "
            "it has no targets, final states or programs to read or score; read its inputs "
            "(read_inputs, EpisodeDataset, predict), and score against the full part")

    def instance_index(self, i: int) -> int:
        """The instance index of position ``i`` (from the manifest; no file is read)."""
        return self._rows[self._position(i)].index

    def _read(self, pos: int, images: bool) -> Episode:
        if self.inputs_only:
            raise self._no_gold()
        g, row = self._group(pos)
        try:
            ep = read_episode(g, images=images)
        except (OSError, KeyError, ValueError) as exc:
            if isinstance(exc, InvalidArgument):
                raise
            msg = (
                f"episode {row.id} in {self._path(row.shard)} cannot be read ({exc}); the "
                "shard is corrupt: re-download or regenerate it"
            )
            raise DataIntegrityError(msg) from exc
        if self.verify and (images or ep.rendering is None):
            got = episode_hash(ep)
            want = row.hash if row.hash is not None else str(g.attrs["content_hash"])
            if got != want:
                msg = (
                    f"episode {row.id} in {self._path(row.shard)} hashes to {got}, but "
                    f"{want} is recorded; the data is corrupt: re-download or regenerate it"
                )
                raise DataIntegrityError(msg)
        return ep

    @overload
    def __getitem__(self, i: int) -> Episode: ...
    @overload
    def __getitem__(self, i: slice) -> list[Episode]: ...
    def __getitem__(self, i: int | slice) -> Episode | list[Episode]:
        if isinstance(i, slice):
            return [self._read(p, True) for p in range(*i.indices(len(self)))]
        return self._read(self._position(int(i)), True)

    def episode(self, i: int, *, images: bool = True) -> Episode:
        """The episode at position ``i``."""
        return self._read(self._position(i), images)

    def position(self, episode_id: str) -> int:
        """The position of episode ``episode_id``."""
        try:
            return self._pos[episode_id]
        except KeyError:
            near = ", ".join(list(self._pos)[:3])
            msg = (
                f"no episode {episode_id!r} in {self.root} ({len(self)} episodes, e.g. "
                f"{near}); list ids with .ids or .index"
            )
            raise UnknownId(msg) from None

    def get(self, episode_id: str, *, images: bool = True) -> Episode:
        """The episode with id ``episode_id`` (:class:`UnknownId` if absent)."""
        return self._read(self.position(episode_id), images)

    def __iter__(self) -> Iterator[Episode]:
        return self.iter_episodes(images=True)

    def iter_episodes(self, *, images: bool = False) -> Iterator[Episode]:
        """Every episode in order; without ``images`` only symbolic parts and targets."""
        for pos in range(len(self)):
            yield self._read(pos, images)

    def read_inputs(self, i: int, *, images: bool = True) -> dict[str, Any]:
        """The model inputs of position ``i`` (see :func:`read_inputs`)."""
        g, _ = self._group(self._position(i))
        return read_inputs(g, images=images)

    def read_targets(self, i: int, arrays: Sequence[str] = TARGET_ARRAYS) -> dict[str, Any]:
        """The targets of position ``i`` (see :func:`read_targets`)."""
        if self.inputs_only:
            raise self._no_gold()
        g, _ = self._group(self._position(i))
        return read_targets(g, arrays)

    def read_item(self, i: int, *, images: bool = True, arrays: Sequence[str] = TARGET_ARRAYS
                  ) -> tuple[dict[str, Any], dict[str, Any] | None]:
        """``(inputs, targets)`` of position ``i`` in one lookup (what a Dataset reads);
        targets are None in an inputs-only part."""
        g, row = self._group(self._position(i))
        try:
            inputs = read_inputs(g, images=images, visible=False)
            return inputs, None if self.inputs_only else read_targets(g, arrays)
        except (OSError, KeyError) as exc:
            msg = (
                f"episode {row.id} in {self._path(row.shard)} cannot be read ({exc}); the "
                "shard is corrupt: re-download or regenerate it"
            )
            raise DataIntegrityError(msg) from exc

    @property
    def ids(self) -> list[str]:
        """Episode ids in order."""
        return [r.id for r in self._rows]

    @property
    def index(self) -> pd.DataFrame:
        """One row per episode: id, split, index, categories and shard file."""
        if self._index is None:
            # the optional categories (phenomenon) are columns only where some episode has them
            keys = [k for k in CATEGORY_KEYS if k not in OPTIONAL_CATEGORY_KEYS
                    or any(k in r.categories for r in self._rows)]
            records = [
                {"id": r.id, "split": self.split, "index": r.index,
                 **{k: r.categories.get(k) for k in keys}, "shard": r.shard}
                for r in self._rows
            ]
            columns = [c for c in INDEX_COLUMNS if c not in CATEGORY_KEYS or c in keys]
            self._index = pd.DataFrame.from_records(records, columns=columns)
        return self._index

    def __repr__(self) -> str:
        return f"EpisodeCollection({str(self.root)!r}, split={self.split!r}, n={len(self)})"


def _open_shard(path: Path, verify: bool) -> EpisodeCollection:
    with _open_h5(path) as f:
        _check_root(f, str(path))
        try:
            rows_json = json.loads(f["index"].asstr()[()])
            split = str(f.attrs.get("split", ""))
        except (KeyError, OSError, ValueError) as exc:
            msg = f"shard {path} has no readable /index ({exc}); it is corrupt: regenerate it"
            raise DataIntegrityError(msg) from exc
    rows = [
        _Row(str(r["id"]), int(r["index"]), path.name, None,
             {k: r[k] for k in CATEGORY_KEYS if k in r})
        for r in rows_json
    ]
    return EpisodeCollection(path, rows, split=split, verify=verify)


def _open_dir(path: Path, verify: bool) -> EpisodeCollection:
    manifest = read_manifest(path / MANIFEST_NAME)
    for s in manifest.shards:
        shard = path / s.file
        if not shard.exists():
            msg = (
                f"shard {shard} listed in the manifest is missing; re-download or "
                "regenerate it"
            )
            raise DataIntegrityError(msg)
        size = shard.stat().st_size
        if size != s.bytes:
            msg = (
                f"shard {shard} is {size} bytes but the manifest says {s.bytes}: it is "
                "truncated or was replaced; re-download or regenerate it"
            )
            raise DataIntegrityError(msg)
        if verify:
            sha = sha256_once(shard)
            if sha != s.sha256:
                msg = (
                    f"shard {shard} has sha256 {sha} but the manifest says {s.sha256}: it "
                    "is corrupt or was replaced; re-download or regenerate it"
                )
                raise DataIntegrityError(msg)
    rows = [
        _Row(e.id, e.index, s.file, e.hash, dict(e.categories))
        for s in manifest.shards
        for e in s.episodes
    ]
    return EpisodeCollection(path, rows, split=manifest.split, manifest=manifest,
                             verify=verify)


def open(
    path: str | os.PathLike[str], *, verify: bool = False, part: str | None = None
) -> EpisodeCollection:
    """Open a shard file or a data directory (with ``manifest.json``) for reading.

    A split root (the directory ``generate --out`` writes, one directory per part) is
    opened at its part ``part``; without ``part`` it is refused with the parts it holds.

    Always checked: format and schema major version, shard sizes against the manifest, and
    each episode's stored content hash against the manifest when it is read. With
    ``verify`` also every shard's sha256 (at open; once per file identity in a process,
    :mod:`~nsrmp_bench.storage.verified_files`) and every episode's recomputed hash (when
    read with images): slower, for ``verify`` runs, the scorer's gold and paranoid readers.
    """
    p = resolve_part(path, part)
    if p.is_dir():
        return _open_dir(p, verify)
    if p.is_file():
        return _open_shard(p, verify)
    hint = (
        " (a '.tmp' file is an unfinished write)"
        if any(p.parent.glob(p.name + "*.tmp")) else ""
    )
    msg = (
        f"{p} does not exist; give a shard file (*{SHARD_SUFFIX}) or a directory with "
        f"{MANIFEST_NAME}{hint}"
    )
    raise InvalidArgument(msg)
