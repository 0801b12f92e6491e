"""``--engine dask``: the bytes of the local pool, a worker killed mid-shard survived, and a
scheduler that goes away is a clear error after which a rerun resumes (127.0.0.1 only)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip("distributed")

from nsrmp_bench.cli.main import main
from nsrmp_bench.engine.dask_cluster import DaskEngine
from nsrmp_bench.errors import EngineError
from nsrmp_bench.generators.generate import generate_part
from nsrmp_bench.split_specs import load_split
from nsrmp_bench.verify import verify

pytestmark = [pytest.mark.sim, pytest.mark.dask, pytest.mark.slow]


def _root(d: Path) -> str:
    return str(json.loads((d / "manifest.json").read_text())["root_hash"])


def _complete(d: Path) -> dict[str, int]:
    """Complete shards -> inode: those under their final name, as a rerun counts them (the
    rename commits a shard; a worker killed before it wrote the record next to it leaves
    a complete shard whose record the rerun rebuilds from the file)."""
    return {p.name: p.stat().st_ino for p in d.glob("shard-*.h5")}


def test_two_workers_from_the_cli_write_the_local_bytes(smoke_dir: Path, tmp_path: Path) -> None:
    assert main(["generate", "--split", "smoke-v2", "--out", str(tmp_path), "--engine", "dask",
                 "--workers", "2", "--shard-size", "3", "--quiet"]) == 0
    assert _root(tmp_path / "test") == _root(smoke_dir / "test")
    assert len(list((tmp_path / "test").glob("shard-*.h5"))) == 6


def test_one_worker_one_shard_writes_the_local_bytes(smoke_dir: Path, tmp_path: Path) -> None:
    with DaskEngine(workers=1) as engine:
        manifest, _ = generate_part(load_split("smoke-v2"), "test", tmp_path, engine=engine,
                                    shard_size=16)
    assert manifest.root_hash == _root(smoke_dir / "test") and len(manifest.shards) == 1


@pytest.fixture()
def cluster() -> Iterator[object]:
    import dask
    from distributed import LocalCluster

    # without Dask's default trim threshold, as DaskEngine starts its own clusters (the
    # nannies would otherwise leak it into this process and later workers warn about it)
    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}), \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                         dashboard_address=None) as c:
        yield c


def test_a_worker_killed_mid_shard_is_survived(cluster: object, smoke_dir: Path,
                                               tmp_path: Path) -> None:
    from distributed import Client

    out = tmp_path / "test"
    address = cluster.scheduler_address  # type: ignore[attr-defined]
    killed: dict[str, object] = {}

    def kill_one_mid_shard(client: Client, pids: dict[str, int]) -> None:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not killed:
            for worker, keys in client.processing().items():
                for key in keys:  # generate_shard-<task>-<run>: task k is shard [4k, 4k+4)
                    k = int(str(key).split("-")[1])
                    tmp = out / f"shard-{4 * k:07d}-{4 * k + 4:07d}.h5.tmp"
                    if tmp.exists() and tmp.stat().st_size > 0:
                        os.kill(pids[worker], signal.SIGKILL)
                        killed.update(worker=worker, pid=pids[worker], shard=tmp.name)
                        return
            time.sleep(0.02)

    with Client(address) as client, DaskEngine(address) as engine:
        pids = client.run(os.getpid)
        killer = threading.Thread(target=kill_one_mid_shard, args=(client, pids))
        killer.start()
        try:
            manifest, _ = generate_part(load_split("smoke-v2"), "test", out, engine=engine,
                                        shard_size=4)
        finally:
            killer.join()
        assert killed, "no worker was caught in the middle of a shard"
        assert killed["pid"] not in client.run(os.getpid).values()  # it really died
        report = verify(out, engine=engine)  # verify on the cluster too
    assert manifest.root_hash == _root(smoke_dir / "test")
    assert report.ok and report.episodes == 16
    assert not list(out.glob("*.tmp")), "the killed worker's partial shard was left behind"
    assert sorted(_complete(out)) == [s.file for s in manifest.shards]


def _start(args: list[str]) -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, "-m", "dask", *args], start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)


def test_a_lost_scheduler_is_a_clear_error_and_a_rerun_resumes(smoke_dir: Path,
                                                                tmp_path: Path) -> None:
    info = tmp_path / "scheduler.json"
    out = tmp_path / "data" / "test"
    scheduler = _start(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                        "--scheduler-file", str(info)])
    worker = _start(["worker", "--scheduler-file", str(info), "--nthreads", "1",
                     "--nworkers", "1", "--host", "127.0.0.1", "--no-dashboard"])
    try:
        deadline = time.monotonic() + 60
        while not info.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(info.read_text())["address"]

        def kill_scheduler_after_one_shard() -> None:
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and not (out.is_dir() and _complete(out)):
                time.sleep(0.02)
            _stop(scheduler)

        killer = threading.Thread(target=kill_scheduler_after_one_shard)
        killer.start()
        try:
            lost = r"scheduler at tcp://127\.0\.0\.1:\d+ went away .*rerun the same command"
            with pytest.raises(EngineError, match=lost), DaskEngine(address) as engine:
                generate_part(load_split("smoke-v2"), "test", out, engine=engine, shard_size=4)
        finally:
            killer.join()
    finally:
        _stop(scheduler)
        _stop(worker)
    assert not (out / "manifest.json").exists(), "a broken run must not look complete"
    before = _complete(out)
    assert 1 <= len(before) < 4
    with DaskEngine(workers=1) as engine:
        manifest, stats = generate_part(load_split("smoke-v2"), "test", out, engine=engine,
                                        shard_size=4)
    assert manifest.root_hash == _root(smoke_dir / "test")
    assert stats.episodes == 16 - 4 * len(before)  # only the missing shards were generated
    after = _complete(out)
    assert all(after[name] == ino for name, ino in before.items())  # kept, not rewritten
