"""A shard's commit hashes its file while another thread fsyncs it: the hash is the file's,
the file is fsynced, and a failure of either reaches the caller."""

from __future__ import annotations

import errno
import hashlib
import os
from pathlib import Path

import numpy as np
import pytest

from nsrmp_bench.canonical import sha256_file
from nsrmp_bench.storage.atomic import fsync_hashing


@pytest.mark.parametrize("size", [0, 1, (1 << 18) - 1, 1 << 18, 3 * (1 << 18) + 5, 5_000_000])
def test_the_hash_is_the_files_whatever_its_size(tmp_path: Path, size: int) -> None:
    data = np.random.default_rng(size).integers(0, 256, size, dtype=np.uint8).tobytes()
    path = tmp_path / "shard.h5.tmp"
    path.write_bytes(data)
    expected = hashlib.sha256(data).hexdigest()
    assert sha256_file(path) == expected
    assert fsync_hashing(path) == expected


def test_the_file_is_fsynced(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "shard.h5.tmp"
    path.write_bytes(b"x" * 100_000)
    synced: list[int] = []
    fsync = os.fsync

    def spy(fd: int) -> None:  # records which file, then syncs it for real
        synced.append(os.fstat(fd).st_ino)
        fsync(fd)

    monkeypatch.setattr(os, "fsync", spy)
    fsync_hashing(path)
    assert synced == [path.stat().st_ino]


def test_a_failed_fsync_reaches_the_caller(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                           ) -> None:
    path = tmp_path / "shard.h5.tmp"
    path.write_bytes(b"x" * 100_000)

    def failing(fd: int) -> None:  # the disk reports an I/O error
        raise OSError(errno.EIO, "Input/output error")

    monkeypatch.setattr(os, "fsync", failing)
    with pytest.raises(OSError, match="Input/output error"):
        fsync_hashing(path)


def test_a_missing_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"gone\.h5\.tmp"):
        fsync_hashing(tmp_path / "gone.h5.tmp")
