"""``download`` as the documentation shows it: the installed CLI, progress bars on.

The console script of the venv the tests run in (installed the README's way,
``pip install -e ".[all,dev]"``) packs smoke-v2, serves it on 127.0.0.1 and downloads it
with progress bars, once more with tqdm unimportable (pooch's own bars need it; ours are
rich). A ValueError from pooch that is not a hash mismatch gets its own message.
"""

from __future__ import annotations

import functools
import http.server
import os
import shutil
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from nsrmp_bench.errors import DownloadError
from nsrmp_bench.release import download

pytestmark = pytest.mark.sim
pytest.importorskip("pooch")


def _cli() -> list[str]:
    script = Path(sys.executable).with_name("nsrmp-bench")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "nsrmp_bench.cli.main"]


@pytest.fixture()
def mirror(smoke_dir: Path, tmp_path: Path) -> Iterator[str]:
    root = tmp_path / "release"
    subprocess.run([*_cli(), "pack", str(smoke_dir), "--out", str(root)], check=True,
                   capture_output=True, timeout=120)
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(root))
    handler.log_message = lambda *a: None  # type: ignore[attr-defined]
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}"
    finally:
        httpd.shutdown()
        httpd.server_close()


@pytest.mark.parametrize("tqdm", ["installed", "missing"])
def test_readme_download_with_progress(mirror: str, tmp_path: Path, tqdm: str) -> None:
    env = dict(os.environ)
    if tqdm == "missing":  # a package named tqdm that cannot be imported shadows the real one
        fake = tmp_path / "no_tqdm" / "tqdm"
        fake.mkdir(parents=True)
        (fake / "__init__.py").write_text("raise ImportError('tqdm is not installed')\n")
        env["PYTHONPATH"] = os.pathsep.join([str(fake.parent), env.get("PYTHONPATH", "")])
    out = tmp_path / "dl"
    proc = subprocess.run(
        [*_cli(), "download", "--split", "smoke-v2", "--out", str(out), "--base-url", mirror],
        env=env, capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "smoke-v2: 1 file verified" in proc.stdout
    assert "corrupted" not in proc.stdout + proc.stderr
    verified = subprocess.run([*_cli(), "verify", str(out / "test")], capture_output=True,
                              text=True, timeout=120)
    assert verified.returncode == 0 and "matches the committed manifest" in verified.stdout
    shutil.rmtree(out)


def test_a_pooch_error_that_is_no_hash_mismatch_is_not_called_corruption(
    mirror: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import pooch

    def refuse(*args: Any, **kwargs: Any) -> None:
        raise ValueError("Missing package 'tqdm' required for progress bars.")

    monkeypatch.setattr(pooch, "retrieve", refuse)
    with pytest.raises(DownloadError) as info:
        download("smoke-v2", tmp_path, base_url=mirror)
    text = str(info.value)
    assert "pooch refused the download (Missing package 'tqdm'" in text
    assert "corrupted" not in text and "does not match" not in text
