"""Storage: sharded HDF5 episodes with manifests, readers, and export/import.

``open(path)`` reads a shard or a data directory; :func:`shard_writer` (a
:class:`ShardWriter`) and :func:`write_dataset` write crash-safely; :func:`episode_hash`
and :func:`root_hash` are the content hashes manifests record. MCAP export (``mcap``
extra) and the import of the original NSRM layout live in :mod:`.mcap_export` and
:mod:`.nsrm_import`.
"""

from __future__ import annotations

from nsrmp_bench.storage.hashing import episode_hash, root_hash
from nsrmp_bench.storage.manifest import Manifest, build_manifest, read_manifest
from nsrmp_bench.storage.reader import (
    EpisodeCollection,
    input_camera,
    open,
    read_episode,
    read_inputs,
    read_targets,
)
from nsrmp_bench.storage.records import EpisodeEntry, ShardRecord
from nsrmp_bench.storage.resume import (
    OutputState,
    record_from_shard,
    scan_output,
    shard_ranges,
    write_dataset,
    write_manifest,
)
from nsrmp_bench.storage.writer import ShardWriter, shard_writer, write_shard

__all__ = [
    "EpisodeCollection",
    "EpisodeEntry",
    "Manifest",
    "OutputState",
    "ShardRecord",
    "ShardWriter",
    "build_manifest",
    "episode_hash",
    "input_camera",
    "open",
    "read_episode",
    "read_inputs",
    "read_manifest",
    "read_targets",
    "record_from_shard",
    "root_hash",
    "scan_output",
    "shard_ranges",
    "shard_writer",
    "write_dataset",
    "write_manifest",
    "write_shard",
]
