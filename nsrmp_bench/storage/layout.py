"""The on-disk layout of an episode shard: names, codecs, dtypes and file naming.

One HDF5 file ("shard") holds the episodes of a contiguous range of instance indices::

    /                                attrs: format, schema_version, units, vocabulary, camera,
                                            split, generator, package_version, dsl,
                                            index_start, index_stop, num_episodes
    /data                            attrs: total                      (robomimic name)
    /data/<episode id>               attrs: id, index, content_hash, num_steps, num_objects,
                                            seed, generator, has_rendering, has_images, camera,
                                            executor
        physics                      scalar UTF-8 string: JSON of the rendering's physics report
        inputs/                      what a model may read (no gold)
            instruction              scalar UTF-8 string
            obs/rgb                  (H, W, 3) uint8         state 0
            obs/depth                (H, W) float32, metres  state 0
            boxes_amodal             (N, 4) float32 pixel xyxy, state 0
            boxes_visible            (N, 4) float32 pixel xyxy, state 0 (NaN = unseen)
        targets/                     gold: later states, boxes, program
            symbolic                 scalar UTF-8 string: canonical JSON of the SymbolicEpisode
            program                  scalar UTF-8 string: the program in functional text form
            obs/rgb                  (S, H, W, 3) uint8      states 1..S
            obs/depth                (S, H, W) float32       states 1..S
            obs/segmentation         (S+1, H, W) int16       states 0..S, -1 = background
            poses                    (S+1, N, 7) float64     xyz + quaternion xyzw
            boxes_amodal             (S+1, N, 4) float32
            boxes_visible            (S+1, N, 4) float32
            visible_fraction         (S+1, N) float32
            depth_centre             (S+1, N) float32
            robot/                   optional trajectory: time, joint_positions, ee_pose,
                                     gripper, step; attrs joint_names
    /mask/<split>                    ids of the shard's episodes (robomimic convention)
    /index                           scalar UTF-8 string: JSON rows (id, index, categories)

Every image is one chunk, compressed with the built-in DEFLATE filter (gzip level 1, byte
shuffle for float depth), so plain h5py and ``h5dump`` read every array without our code.
Files are byte-deterministic: no timestamps, fixed ``libver`` bounds.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Final

import h5py
import numpy as np

from nsrmp_bench.errors import InvalidArgument, SchemaVersionError
from nsrmp_bench.storage import h5_objects

if TYPE_CHECKING:
    from numpy.typing import DTypeLike

__all__ = [
    "ARRAY_SPECS",
    "DATA_WRITER_VERSION",
    "FORMAT",
    "LIBVER",
    "RECORD_SUFFIX",
    "SHARD_SUFFIX",
    "SUPPORTED_MAJOR",
    "TMP_SUFFIX",
    "ArraySpec",
    "check_episode_id",
    "check_schema_version",
    "create_group",
    "image_codec",
    "parse_shard_filename",
    "shard_filename",
    "small_codec",
]

FORMAT: Final = "nsrmp-bench-episodes"
"""Value of the root ``format`` attribute of every shard."""

DATA_WRITER_VERSION: Final = "0.1.0"
"""What every shard records as ``package_version`` and every manifest as its
``versions["nsrmp-bench"]``: the nsrmp-bench version whose writer makes these bytes. It
changes when the writer's bytes change, not with every release of the package, so that a
release leaves the committed shards and manifests byte for byte (``verify``, ``download``)."""

SUPPORTED_MAJOR: Final = 1
"""The schema major version this reader understands."""

LIBVER: Final = ("v110", "v110")
"""HDF5 file-format bounds: fixed, so that the same episodes give the same bytes on any
HDF5 >= 1.10, and readable by HDF5 1.10 tools."""

SHARD_SUFFIX: Final = ".h5"
TMP_SUFFIX: Final = ".tmp"
RECORD_SUFFIX: Final = ".record.json"
"""A shard ``X.h5`` is complete when ``X.h5.record.json`` exists and its sha256 matches."""

_SHARD_RE: Final = re.compile(r"^shard-(\d{7})-(\d{7})\.h5$")
_ID_RE: Final = re.compile(r"^[A-Za-z0-9_\-.:+=@,]+$")


def shard_filename(start: int, stop: int) -> str:
    """File name of the shard holding instance indices ``start <= i < stop``."""
    if not 0 <= start < stop <= 9_999_999:
        msg = (
            f"a shard covers a non-empty index range within [0, 9999999]; "
            f"got start={start}, stop={stop}"
        )
        raise InvalidArgument(msg)
    return f"shard-{start:07d}-{stop:07d}{SHARD_SUFFIX}"


def parse_shard_filename(name: str) -> tuple[int, int] | None:
    """The ``(start, stop)`` index range of a shard file name, or None if it is not one."""
    m = _SHARD_RE.match(name)
    if m is None:
        return None
    start, stop = int(m.group(1)), int(m.group(2))
    return (start, stop) if start < stop else None


def check_episode_id(episode_id: str) -> str:
    """Return ``episode_id`` if it can name an HDF5 group, else raise InvalidArgument."""
    if not _ID_RE.match(episode_id) or episode_id in {".", ".."}:
        msg = (
            f"episode id {episode_id!r} cannot name an HDF5 group; ids may use letters, "
            "digits and _-.:+=@, (no '/' or spaces): rename the episode"
        )
        raise InvalidArgument(msg)
    return episode_id


def check_schema_version(version: object, where: str, supported: int = SUPPORTED_MAJOR) -> str:
    """Accept a semver string of major version ``supported``; raise SchemaVersionError."""
    text = version.decode() if isinstance(version, bytes) else str(version)
    parts = text.split(".")
    if len(parts) != 3 or not all(p.isdigit() for p in parts):
        msg = (
            f"{where}: schema_version {text!r} is not a semantic version MAJOR.MINOR.PATCH; "
            "the file was not written by nsrmp-bench or is damaged: regenerate or re-download it"
        )
        raise SchemaVersionError(msg)
    major = int(parts[0])
    if major != supported:
        hint = (
            "upgrade nsrmp-bench (pip install -U nsrmp-bench)"
            if major > supported
            else "regenerate the data with this version, or read it with an older nsrmp-bench"
        )
        msg = (
            f"{where}: schema_version {text} has major version {major}, but this nsrmp-bench "
            f"reads major version {supported} only; {hint}"
        )
        raise SchemaVersionError(msg)
    return text


@dataclass(frozen=True)
class ArraySpec:
    """One logical array of an episode: its name, dtype and rank."""

    name: str
    dtype: np.dtype[Any]
    ndim: int


def _spec(name: str, dtype: DTypeLike, ndim: int) -> ArraySpec:
    return ArraySpec(name, np.dtype(dtype).newbyteorder("<"), ndim)


ARRAY_SPECS: Final[tuple[ArraySpec, ...]] = (
    _spec("observations/rgb", np.uint8, 4),
    _spec("observations/depth", np.float32, 3),
    _spec("observations/segmentation", np.int16, 3),
    _spec("targets/poses", np.float64, 3),
    _spec("targets/boxes_amodal", np.float32, 3),
    _spec("targets/boxes_visible", np.float32, 3),
    _spec("targets/visible_fraction", np.float32, 2),
    _spec("targets/depth_centre", np.float32, 2),
    _spec("trajectory/time", np.float64, 1),
    _spec("trajectory/joint_positions", np.float64, 2),
    _spec("trajectory/ee_pose", np.float64, 2),
    _spec("trajectory/gripper", np.float64, 1),
    _spec("trajectory/step", np.int16, 1),
)
"""Every array an episode can hold, in hashing order, with its stored dtype."""


def image_codec(shape: tuple[int, ...], dtype: np.dtype[Any], *, stacked: bool) -> dict[str, Any]:
    """h5py dataset keywords for images: one image per chunk, DEFLATE level 1.

    ``shape`` is one image ``(H, W[, C])`` or, when ``stacked``, a stack ``(K, H, W[, C])``.
    Float images also get the byte-shuffle filter. Level 1 was measured against 4 and 6 on
    rendered episodes (``tests/bench/test_storage_bench.py --codecs``): about 5 % larger
    than level 4, but about 40 % faster to write and 20-30 % faster to read.
    """
    if 0 in shape:
        return {}
    chunks = (1, *shape[1:]) if stacked else shape
    kw: dict[str, Any] = {"chunks": chunks, "compression": "gzip", "compression_opts": 1}
    if dtype.kind == "f":
        kw["shuffle"] = True
    return kw


def small_codec() -> dict[str, Any]:
    """h5py dataset keywords for small per-object arrays: contiguous, unfiltered."""
    return {}


def create_group(parent: h5py.Group, name: str) -> h5py.Group:
    """Create a group without creation/modification times (byte-deterministic files)."""
    return h5py.Group(h5_objects.group(parent.id, name))
