"""The machine's faults are sentences and exit 2, never tracebacks or half-written files:
a full disk and a read-only folder (real ones: small tmpfs mounts, where this process may
mount; skipped elsewhere), a second writer of a part folder, writers racing for one file.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from nsrmp_bench.cli.main import main
from nsrmp_bench.errors import ResourceLimit
from nsrmp_bench.storage.atomic import atomic_write_text
from nsrmp_bench.storage.disk_faults import disk_fault
from nsrmp_bench.storage.folder_lock import LOCK_NAME, folder_lock

REPO = Path(__file__).resolve().parents[2]
ORACLE = REPO / "leaderboards" / "predictions" / "smoke-v2-test--oracle-v1.jsonl.gz"


def _mount(where: Path, options: str) -> Iterator[Path]:
    where.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)],
                          capture_output=True, check=False)
    if done.returncode != 0:
        pytest.skip("cannot mount a tmpfs here (needs root): no real full or read-only disk")
    try:
        yield where
    finally:
        subprocess.run(["umount", str(where)], capture_output=True, check=False)


@pytest.fixture()
def full_disk(tmp_path: Path) -> Iterator[Path]:
    """A 256 kB tmpfs, filled up."""
    if shutil.which("mount") is None:
        pytest.skip("no mount command")
    for disk in _mount(tmp_path / "full", "size=256k"):
        fd = os.open(disk / "filler", os.O_WRONLY | os.O_CREAT)
        try:
            with pytest.raises(OSError, match="No space left"):
                while True:
                    os.write(fd, b"\0" * 4096)
        finally:
            os.close(fd)
        yield disk


@pytest.fixture()
def read_only(tmp_path: Path) -> Iterator[Path]:
    if shutil.which("mount") is None:
        pytest.skip("no mount command")
    yield from _mount(tmp_path / "ro", "ro,size=64k")


def _said(capsys: pytest.CaptureFixture[str], *words: str) -> None:
    err = capsys.readouterr().err
    assert "Traceback" not in err and "error: could not write" in err, err
    for w in words:
        assert w in err, err


def test_a_write_onto_a_full_disk_or_a_read_only_folder_leaves_nothing_and_is_said(
    full_disk: Path, read_only: Path
) -> None:
    for disk, words in ((full_disk, ("the disk is full", "ENOSPC")),
                        (read_only, ("read-only file system", "EROFS"))):
        with pytest.raises(OSError) as caught:
            atomic_write_text(disk / "out.json", "x" * 300_000)
        sentence = disk_fault(caught.value)
        assert sentence is not None
        for w in words:
            assert w in sentence
        assert not (disk / "out.json").exists()
        assert not list(disk.glob("*.tmp"))


@pytest.mark.sim
def test_score_json_onto_a_full_disk_is_a_sentence(
    smoke_v2_test: Path, full_disk: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = full_disk / "scores.json"
    assert main(["score", str(ORACLE), "--data", str(smoke_v2_test), "--n-boot", "0",
                 "--quiet", "--json", str(out)]) == 2
    _said(capsys, "the disk is full", "run the same command again")
    assert not out.exists() and not list(full_disk.glob("*.tmp"))


@pytest.mark.sim
def test_generate_and_baseline_into_a_read_only_folder_are_sentences(
    smoke_v2_test: Path, read_only: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["generate", "--split", "smoke-v2", "--out", str(read_only / "smoke"),
                 "--quiet"]) == 2
    _said(capsys, "read-only file system")
    assert main(["baseline", "noop", "--data", str(smoke_v2_test), "--out",
                 str(read_only / "noop.jsonl")]) == 2
    _said(capsys, "read-only file system")


@pytest.mark.sim
def test_pack_onto_a_full_disk_leaves_no_shard_under_its_final_name(
    smoke_v2_root: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    shard = max((smoke_v2_root / "test").glob("shard-*.h5"), key=lambda p: p.stat().st_size)
    half = max(64, shard.stat().st_size // 2048)  # kB: the disk fills mid-shard
    for disk in _mount(tmp_path / "small", f"size={half}k"):
        assert main(["pack", str(smoke_v2_root), "--out", str(disk / "release")]) == 2
        _said(capsys, "the disk is full")
        assert not list(disk.rglob("shard-*.h5")), list(disk.rglob("*"))
        assert not list(disk.rglob("*.tmp"))


@pytest.mark.sim  # the command reaches the lock only where PyBullet is installed
def test_a_second_generate_into_a_held_folder_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    part = tmp_path / "smoke" / "test"
    with folder_lock(part, "generate"):
        with pytest.raises(ResourceLimit, match=r"being written by another generate"), \
                folder_lock(part, "generate"):
            pass
        assert main(["generate", "--split", "smoke-v2", "--out", str(tmp_path / "smoke"),
                     "--quiet"]) == 2
        err = capsys.readouterr().err
        assert "being written by another generate (process" in err and "Traceback" not in err
    assert not (part / LOCK_NAME).exists(), "the lock file goes when the work ends"
    with folder_lock(part, "generate"):  # free again
        pass


def test_six_writers_of_one_file_leave_one_whole_file(tmp_path: Path) -> None:
    out = tmp_path / "scores.json"
    texts = [json.dumps({"writer": k, "pad": "x" * 200_000}) for k in range(6)]
    errors: list[BaseException] = []

    def write(text: str) -> None:
        try:
            atomic_write_text(out, text)
        except BaseException as exc:
            errors.append(exc)

    threads = [threading.Thread(target=write, args=(t,)) for t in texts]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert out.read_text() in texts
    assert not list(tmp_path.glob("*.tmp"))


@pytest.mark.sim
def test_generate_onto_a_full_disk_is_a_sentence_naming_the_shard(
    full_disk: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (full_disk / "filler").unlink()  # room to start, not to finish a shard
    for workers in ("1", "2"):  # the writer process, and a worker of the pool
        assert main(["generate", "--split", "smoke-v2", "--out", str(full_disk / "smoke"),
                     "--workers", workers, "--quiet"]) == 2
        _said(capsys, "shard-0000000-0000016.h5", "the disk is full")
        assert not list(full_disk.rglob("*.h5")) and not list(full_disk.rglob("*.tmp"))
        assert not list(full_disk.rglob(LOCK_NAME))
