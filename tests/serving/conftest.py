"""Policy servers in their own processes, on 127.0.0.1, each stopped by its test."""

from __future__ import annotations

import os
import queue
import subprocess
import sys
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import pytest

START_SECONDS = 90.0  # a cold start imports gymnasium and PyBullet under load


@contextmanager
def served(args: Sequence[str], *, cwd: Path, env: dict[str, str] | None = None
           ) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """``nsrmp-bench serve ARGS --port 0`` in a child process; (its URL, the process)."""
    code = "from nsrmp_bench.cli.main import main; raise SystemExit(main())"
    full_env = {**os.environ, **(env or {}), "PYTHONPATH": os.pathsep.join(
        [str(cwd), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen([sys.executable, "-c", code, "serve", *args, "--port", "0"],
                            cwd=cwd, env=full_env, stderr=subprocess.PIPE, text=True)
    lines: queue.Queue[str] = queue.Queue()

    def pump() -> None:
        assert proc.stderr is not None
        for line in proc.stderr:
            lines.put(line)

    threading.Thread(target=pump, daemon=True).start()
    try:
        seen = []
        while True:
            try:
                line = lines.get(timeout=START_SECONDS)
            except queue.Empty:
                pytest.fail(f"the server did not start within {START_SECONDS} s: {seen}")
            seen.append(line)
            if line.startswith("serving ") and " on ws://" in line:
                yield line.rsplit(" on ", 1)[1].strip(), proc
                return
            if proc.poll() is not None:
                pytest.fail(f"the server exited {proc.returncode}: {''.join(seen)}")
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait(timeout=30)


@pytest.fixture()
def serve_process() -> object:
    """The :func:`served` context manager."""
    return served
