"""Generation: same bytes for any worker count and shard size; resume after a kill."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from nsrmp_bench.official_manifests import official_manifest
from nsrmp_bench.storage.reader import open as open_data

pytestmark = pytest.mark.sim


def _manifest(d: Path) -> dict:
    return json.loads((d / "manifest.json").read_text())


def test_same_episodes_for_any_workers_and_shard_size(smoke_dir: Path, tmp_path: Path) -> None:
    from nsrmp_bench.generators.generate import generate_split

    generate_split("smoke-v2", tmp_path, workers=1, shard_size=5)
    a, b = _manifest(smoke_dir / "test"), _manifest(tmp_path / "test")
    assert a["root_hash"] == b["root_hash"]
    assert [e["hash"] for e in a["episodes"]] == [e["hash"] for e in b["episodes"]]
    assert len(b["shards"]) == 4 and len(a["shards"]) == 1
    assert a["versions"]["physics_fingerprint"] == b["versions"]["physics_fingerprint"]


def test_matches_the_committed_manifest(smoke_dir: Path) -> None:
    committed = official_manifest("smoke-v2", "test")
    if committed is None:
        pytest.skip("no committed manifest for smoke-v2 yet")
    assert _manifest(smoke_dir / "test")["root_hash"] == committed["root_hash"]


def test_every_episode_is_rendered_and_categorised(smoke_dir: Path) -> None:
    with open_data(smoke_dir / "test") as data:
        assert len(data) == 16
        frame = data.index
        assert set(frame["steps"]) == set(range(1, 8))
        assert frame["objects"].min() == 3 and frame["objects"].max() == 15
        ep = data[0]
        assert ep.rendering is not None and ep.rendering.observations is not None
        assert ep.rendering.observations.rgb.shape[1:] == (240, 320, 3)


def test_resume_after_kill_reaches_the_same_manifest(smoke_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "killed"
    cmd = [sys.executable, "-m", "nsrmp_bench.cli.main", "generate", "--split", "smoke-v2",
           "--out", str(out), "--workers", "1", "--shard-size", "4", "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    part = out / "test"
    while time.monotonic() < deadline:
        if part.is_dir() and any(part.glob("shard-*.h5")):
            break
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not (part / "manifest.json").exists(), "a killed run must not look complete"
    done = {p.name for p in part.glob("shard-*.h5")}
    assert 1 <= len(done) < 4
    resumed = subprocess.run(cmd, capture_output=True, text=True, check=True)
    assert "root hash" in resumed.stderr
    assert _manifest(part)["root_hash"] == _manifest(smoke_dir / "test")["root_hash"]
    assert not list(part.glob("*.tmp"))


def test_a_writer_process_only_where_every_generating_process_leaves_a_core() -> None:
    from nsrmp_bench.engine import InlineEngine, LocalPoolEngine
    from nsrmp_bench.generators.generate import shard_writer_mode

    cores = len(os.sched_getaffinity(0))
    assert shard_writer_mode(InlineEngine()) == ("process" if cores >= 2 else True)
    assert shard_writer_mode(LocalPoolEngine(cores)) is True  # every core generates
    assert shard_writer_mode(LocalPoolEngine(max(1, cores // 2))) == (
        "process" if cores >= 2 else True)
