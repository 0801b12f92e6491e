"""Readers fail clearly on unknown schema versions, truncated or corrupt files, hash mismatch."""

from __future__ import annotations

import json
import os
from pathlib import Path

import h5py
import pytest
from storage_factory import make_episode, make_mixed

from nsrmp_bench.errors import DataIntegrityError, InvalidArgument, SchemaVersionError
from nsrmp_bench.storage import open, write_dataset, write_shard

SHARD = "shard-0000000-0000004.h5"


@pytest.fixture
def data(tmp_path: Path) -> Path:
    write_dataset(tmp_path, make_mixed, 0, 4, shard_size=4, split="test-v1")
    return tmp_path


@pytest.mark.parametrize(("version", "hint"), [("2.0.0", "upgrade nsrmp-bench"),
                                               ("0.9.0", "older nsrmp-bench")])
def test_unknown_major_version_says_what_to_do(data: Path, version: str, hint: str) -> None:
    with h5py.File(data / SHARD, "a") as f:
        f.attrs["schema_version"] = version
    with pytest.raises(SchemaVersionError, match=rf"schema_version {version}.*{hint}"):
        open(data / SHARD)


def test_newer_minor_version_is_accepted(data: Path) -> None:
    with h5py.File(data / SHARD, "a") as f:
        f.attrs["schema_version"] = "1.7.0"
    assert len(list(open(data / SHARD))) == 4


def test_manifest_of_unknown_major_version(data: Path) -> None:
    m = json.loads((data / "manifest.json").read_text())
    m["schema_version"] = "3.1.0"
    (data / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(SchemaVersionError, match=r"3\.1\.0.*upgrade"):
        open(data)


def test_truncated_shard(data: Path) -> None:
    size = (data / SHARD).stat().st_size
    with (data / SHARD).open("r+b") as fh:
        fh.truncate(size // 2)
    with pytest.raises(DataIntegrityError, match="truncated or corrupt"):
        open(data / SHARD)
    with pytest.raises(DataIntegrityError, match=r"bytes but the manifest says .*truncated"):
        open(data)


def test_shard_replaced_by_another_valid_shard(tmp_path: Path) -> None:
    write_dataset(tmp_path / "a", make_mixed, 0, 4, shard_size=4, split="test-v1")
    write_dataset(tmp_path / "b", lambda i: make_mixed(i, entropy=99), 0, 4, shard_size=4,
                  split="test-v1")
    os.replace(tmp_path / "b" / SHARD, tmp_path / "a" / SHARD)
    with pytest.raises(DataIntegrityError, match="manifest"):
        coll = open(tmp_path / "a")
        coll[0]


def test_hash_in_manifest_disagrees(data: Path) -> None:
    m = json.loads((data / "manifest.json").read_text())
    m["episodes"][1]["hash"] = "0" * 64
    (data / "manifest.json").write_text(json.dumps(m))
    coll = open(data)
    coll[0]
    with pytest.raises(DataIntegrityError, match=r"content hash .* but the manifest says 0000"):
        coll[1]


def test_flipped_byte_is_caught_by_verify(data: Path) -> None:
    path = data / SHARD
    blob = bytearray(path.read_bytes())
    with h5py.File(path, "r") as f:  # flip a byte inside an image chunk
        offset = f["data/test-v1-000000/targets/obs/rgb"].id.get_chunk_info(0).byte_offset
    blob[offset + 40] ^= 0xFF
    path.write_bytes(bytes(blob))
    with pytest.raises(DataIntegrityError, match=r"sha256 .* but the manifest says"):
        open(data, verify=True)
    coll = open(data)  # sizes agree, so only the read itself can tell
    with pytest.raises(DataIntegrityError, match=r"cannot be read .*corrupt"):
        coll[0]
    assert coll.episode(0, images=False).id == "test-v1-000000"  # the targets are intact


def test_missing_manifest_and_missing_path(tmp_path: Path) -> None:
    write_shard(tmp_path, 0, [make_episode(0)], split="s")
    (tmp_path / "manifest.json").unlink(missing_ok=True)
    with pytest.raises(DataIntegrityError, match=r"no manifest .*open a single shard"):
        open(tmp_path)
    with pytest.raises(InvalidArgument, match="does not exist"):
        open(tmp_path / "nope.h5")


def test_not_our_file(tmp_path: Path) -> None:
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f["x"] = 1
    with pytest.raises(DataIntegrityError, match="not written by nsrmp-bench"):
        open(tmp_path / "other.h5")
    (tmp_path / "junk.h5").write_bytes(b"not hdf5 at all")
    with pytest.raises(DataIntegrityError, match="cannot be opened as HDF5"):
        open(tmp_path / "junk.h5")
