"""``rollout --server`` against ``nsrmp-bench serve`` in another process (127.0.0.1): the
same bytes as in process, a killed server, resuming, a silent server."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("gymnasium")
pytest.importorskip("pybullet")
pytest.importorskip("websockets")

from nsrmp_bench.cli.main import main

pytestmark = pytest.mark.sim

LIMIT = "5"

# a deterministic policy that reads no environment (a module:callable): the first object
# onto the second, then done; NSRMP_TEST_EXIT_AT kills its process at that call
POLICY = '''
import os

calls = 0


def policy(observation):
    global calls
    calls += 1
    if str(calls) == os.environ.get("NSRMP_TEST_EXIT_AT"):
        os._exit(3)
    if os.environ.get("NSRMP_TEST_SLEEP"):
        import time
        time.sleep(float(os.environ["NSRMP_TEST_SLEEP"]))
    return {"done": 1} if calls % 2 == 0 else {"step": [0, 0, 1]}
'''


def test_oracle_over_the_server_gives_the_same_bytes(smoke_v2_test: Path, tmp_path: Path,
                                                     serve_process: Any) -> None:
    local = tmp_path / "local.jsonl"
    assert main(["rollout", "oracle", "--data", str(smoke_v2_test), "--out", str(local),
                 "--limit", LIMIT, "--quiet"]) == 0
    remote = tmp_path / "remote.jsonl"
    with serve_process(["oracle", "--data", str(smoke_v2_test)], cwd=tmp_path) as (url, _):
        assert main(["rollout", "--server", url, "--data", str(smoke_v2_test), "--out",
                     str(remote), "--limit", LIMIT, "--quiet", "--timeout", "60"]) == 0
    assert remote.read_bytes() == local.read_bytes()
    assert not (tmp_path / "remote.jsonl.journal").exists()


def test_a_killed_server_stops_the_run_and_a_rerun_resumes_to_the_same_bytes(
        smoke_v2_test: Path, tmp_path: Path, serve_process: Any,
        capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "alternating.py").write_text(POLICY)
    args = ["--data", str(smoke_v2_test), "--limit", LIMIT, "--boxes", "gold", "--quiet",
            "--retries", "1", "--connect-timeout", "5"]
    whole = tmp_path / "whole.jsonl"
    with serve_process(["alternating:policy"], cwd=tmp_path) as (url, _):
        assert main(["rollout", "--server", url, "--out", str(whole), *args]) == 0
    out = tmp_path / "resumed.jsonl"
    journal = tmp_path / "resumed.jsonl.journal"
    with serve_process(["alternating:policy"], cwd=tmp_path,
                       env={"NSRMP_TEST_EXIT_AT": "5"}) as (url, proc):
        assert main(["rollout", "--server", url, "--out", str(out), *args]) != 0
        assert proc.wait(timeout=30) == 3
    err = capsys.readouterr().err
    assert "rerun the same command to resume" in err
    assert not out.exists()  # nothing that looks complete
    assert len(journal.read_text().splitlines()) == 1 + 2  # two instances were done
    with serve_process(["alternating:policy"], cwd=tmp_path) as (url, _):
        assert main(["rollout", "--server", url, "--out", str(out), *args]) == 0
    assert out.read_bytes() == whole.read_bytes()
    assert not journal.exists()


def test_a_silent_server_is_reported_within_the_timeout(
        smoke_v2_test: Path, tmp_path: Path, serve_process: Any,
        capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "alternating.py").write_text(POLICY)
    out = tmp_path / "p.jsonl"
    with serve_process(["alternating:policy"], cwd=tmp_path,
                       env={"NSRMP_TEST_SLEEP": "60"}) as (url, _):
        t0 = time.monotonic()
        assert main(["rollout", "--server", url, "--data", str(smoke_v2_test), "--out",
                     str(out), "--limit", "2", "--timeout", "2", "--quiet"]) != 0
        assert time.monotonic() - t0 < 30
    err = capsys.readouterr().err
    assert "sent no reply to observation seq" in err and "within 2 s" in err
    assert not out.exists()


def test_no_server_is_a_sentence(smoke_v2_test: Path, tmp_path: Path,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    import socket

    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    out = tmp_path / "p.jsonl"
    assert main(["rollout", "--server", f"ws://127.0.0.1:{port}", "--data",
                 str(smoke_v2_test), "--out", str(out), "--connect-timeout", "2",
                 "--quiet"]) != 0
    assert "cannot connect to the policy server" in capsys.readouterr().err
    assert not out.exists()


def test_a_restarted_server_is_reconnected_to_and_the_bytes_hold(
        smoke_v2_test: Path, tmp_path: Path, serve_process: Any) -> None:
    import os
    import socket
    import subprocess
    import sys
    import threading

    (tmp_path / "alternating.py").write_text(POLICY)
    args = ["--data", str(smoke_v2_test), "--limit", LIMIT, "--boxes", "gold", "--quiet"]
    whole = tmp_path / "whole.jsonl"
    with serve_process(["alternating:policy"], cwd=tmp_path) as (url, _):
        assert main(["rollout", "--server", url, "--out", str(whole), *args]) == 0
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    code = "from nsrmp_bench.cli.main import main; raise SystemExit(main())"
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}

    def start(extra: dict[str, str]) -> subprocess.Popen[str]:
        return subprocess.Popen([sys.executable, "-c", code, "serve", "alternating:policy",
                                 "--port", str(port)], cwd=tmp_path, env={**env, **extra},
                                stderr=subprocess.PIPE, text=True)

    first = start({"NSRMP_TEST_EXIT_AT": "3"})  # dies in the second episode
    assert first.stderr is not None
    for line in first.stderr:  # until it listens
        if line.startswith("serving "):
            break
    second: list[subprocess.Popen[str]] = []

    def restart() -> None:
        first.wait(timeout=120)
        second.append(start({}))

    watcher = threading.Thread(target=restart, daemon=True)
    watcher.start()
    out = tmp_path / "reconnected.jsonl"
    try:
        assert main(["rollout", "--server", f"ws://127.0.0.1:{port}", "--out", str(out),
                     "--retries", "10", *args]) == 0
    finally:
        watcher.join(timeout=120)
        for proc in (first, *second):
            if proc.poll() is None:
                proc.kill()
            proc.wait(timeout=30)
    assert out.read_bytes() == whole.read_bytes()
