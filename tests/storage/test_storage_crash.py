"""Crash safety: a writer SIGKILLed mid-shard leaves nothing complete-looking; resume is exact."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from storage_factory import make_mixed

from nsrmp_bench.errors import DataIntegrityError
from nsrmp_bench.storage import open, scan_output, write_dataset

HERE = Path(__file__).resolve().parent
STOP, SHARD_SIZE, BLOCK_AT = 11, 4, 6  # shards [0,4) [4,8) [8,11); killed inside [4,8)

CHILD = """
import sys, time
sys.path.insert(0, {here!r})
from storage_factory import make_mixed
from nsrmp_bench.storage import write_dataset
def make(i):
    if i == {block}:
        print("BLOCKED", flush=True)
        time.sleep(600)
    return make_mixed(i, entropy={entropy})
write_dataset({out!r}, make, 0, {stop}, shard_size={size}, split="test-v1",
              versions={{"pybullet": "3.2.7"}})
"""


@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL is POSIX")
def test_sigkill_mid_shard_then_resume_reaches_identical_manifest(tmp_path: Path) -> None:
    out = tmp_path / "killed"
    code = CHILD.format(here=str(HERE), block=BLOCK_AT, entropy=7, out=str(out), stop=STOP,
                        size=SHARD_SIZE)
    child = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "BLOCKED"
        os.kill(child.pid, signal.SIGKILL)
    finally:
        child.wait(timeout=30)
    assert child.returncode == -signal.SIGKILL

    # 1. nothing that looks complete: the killed shard only exists as .tmp, no manifest
    names = sorted(p.name for p in out.iterdir())
    assert names == [
        "shard-0000000-0000004.h5",
        "shard-0000000-0000004.h5.record.json",
        "shard-0000004-0000008.h5.tmp",
    ]
    with pytest.raises(DataIntegrityError):  # the partial file is not a readable shard
        open(out / "shard-0000004-0000008.h5.tmp")
    with pytest.raises(DataIntegrityError, match="no manifest"):
        open(out)

    # 2. the partial work is detected; the complete shard is kept
    state = scan_output(out)
    assert [r.file for r in state.complete] == ["shard-0000000-0000004.h5"]
    assert state.removed == ("shard-0000004-0000008.h5.tmp",)
    assert state.missing(0, STOP, SHARD_SIZE) == [(4, 8), (8, 11)]

    # 3. resuming makes only the missing shards and reaches the uninterrupted result
    made: list[int] = []

    def make(i: int):  # type: ignore[no-untyped-def]
        made.append(i)
        return make_mixed(i, entropy=7)

    resumed = write_dataset(out, make, 0, STOP, shard_size=SHARD_SIZE, split="test-v1",
                            versions={"pybullet": "3.2.7"})
    assert made == list(range(4, STOP))
    clean = write_dataset(tmp_path / "clean", make_mixed, 0, STOP, shard_size=SHARD_SIZE,
                          split="test-v1", versions={"pybullet": "3.2.7"})
    assert resumed == clean
    assert (out / "manifest.json").read_bytes() == (tmp_path / "clean/manifest.json").read_bytes()
    assert len(open(out, verify=True)) == STOP


def test_killed_between_rename_and_record_is_recovered(tmp_path: Path) -> None:
    m = write_dataset(tmp_path, make_mixed, 0, 6, shard_size=3, split="test-v1")
    (tmp_path / "shard-0000003-0000006.h5.record.json").unlink()
    (tmp_path / "manifest.json").unlink()
    state = scan_output(tmp_path)
    assert state.recovered == ("shard-0000003-0000006.h5",)
    assert [r.file for r in state.complete] == [s.file for s in m.shards]
    assert write_dataset(tmp_path, make_mixed, 0, 6, shard_size=3, split="test-v1") == m


def test_corrupt_complete_shard_is_removed_and_regenerated(tmp_path: Path) -> None:
    m = write_dataset(tmp_path, make_mixed, 0, 6, shard_size=3, split="test-v1")
    path = tmp_path / "shard-0000000-0000003.h5"
    blob = bytearray(path.read_bytes())
    blob[len(blob) // 2] ^= 0x01
    path.write_bytes(bytes(blob))
    state = scan_output(tmp_path)
    assert state.removed == ("shard-0000000-0000003.h5",)
    assert write_dataset(tmp_path, make_mixed, 0, 6, shard_size=3, split="test-v1") == m


def test_exception_in_factory_leaves_no_tmp(tmp_path: Path) -> None:
    def broken(i: int):  # type: ignore[no-untyped-def]
        if i == 4:
            raise RuntimeError("boom")
        return make_mixed(i)

    with pytest.raises(RuntimeError, match="boom"):
        write_dataset(tmp_path, broken, 0, 6, shard_size=3, split="test-v1")
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "shard-0000000-0000003.h5", "shard-0000000-0000003.h5.record.json"]
