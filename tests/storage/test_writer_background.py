"""The writer thread (zlib, direct chunk writes) writes the same bytes as HDF5's filters."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

pytest.importorskip("pybullet")

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage import open as open_part
from nsrmp_bench.storage.writer import ShardWriter


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_background_writer_writes_the_bytes_of_the_synchronous_one(
    smoke_v2_test: Path, tmp_path: Path
) -> None:
    with open_part(smoke_v2_test) as part:
        episodes = [part.episode(i) for i in range(len(part))]
    shas = {}
    for background in (False, True):
        out = tmp_path / f"background-{background}"
        with ShardWriter(out, 0, len(episodes), split="smoke-v2/test",
                         background=background, queue_size=1) as w:
            for ep in episodes:
                w.add(ep)
            record = w.commit()
        shas[background] = (_sha(out / record.file), record.sha256,
                            [e.hash for e in record.episodes])
    assert shas[True] == shas[False]
    # and both are the shard the generator made
    committed = next(smoke_v2_test.glob("shard-*.h5"))
    assert shas[True][0] == _sha(committed)


def test_an_error_on_the_writer_thread_surfaces_and_leaves_no_file(
    smoke_v2_test: Path, tmp_path: Path
) -> None:
    with open_part(smoke_v2_test) as part:
        first = part.episode(0)
    w = ShardWriter(tmp_path, 0, 1, split="smoke-v2/test")
    w._data.create_group(first.id)  # the writer thread will find the episode's name taken
    w.add(first)
    with pytest.raises(RuntimeError, match=r"writing shard shard-0000000-0000001\.h5 failed"):
        w.commit()
    assert not list(tmp_path.glob("*.h5*"))


def test_queue_size_must_be_positive(tmp_path: Path) -> None:
    with pytest.raises(InvalidArgument, match="queue_size must be at least 1, got 0"):
        ShardWriter(tmp_path, 0, 1, split="x/test", queue_size=0)
