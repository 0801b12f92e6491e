"""``download`` from a hostile mirror: its registry's paths stay inside ``--out``, and a
file already there is never replaced unasked.

The mirror is a real HTTP server on 127.0.0.1 serving a folder this test writes; the split
is no shipped one, so its registry is the mirror's own ``registry.txt``.
"""

from __future__ import annotations

import functools
import hashlib
import http.server
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from nsrmp_bench.cli.main import main
from nsrmp_bench.errors import DownloadError
from nsrmp_bench.release import download

pytest.importorskip("pooch")

SPLIT = "mirrored-v1"
PAYLOAD = b"attacker's bytes\n"
SHA = hashlib.sha256(PAYLOAD).hexdigest()


@pytest.fixture()
def mirror(tmp_path: Path) -> Iterator[tuple[str, Path]]:
    root = tmp_path / "mirror"
    (root / SPLIT / "test").mkdir(parents=True)
    (root / SPLIT / "test" / "shard.h5").write_bytes(PAYLOAD)
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(root))
    handler.log_message = lambda *a: None  # type: ignore[attr-defined]
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}", root / SPLIT
    finally:
        httpd.shutdown()
        httpd.server_close()


def _registry(split_dir: Path, path: str) -> None:
    (split_dir / "registry.txt").write_text(f"{path} {SHA} {len(PAYLOAD)}\n")


@pytest.mark.parametrize("path", ["../../x", "test/../../x", "/tmp/nsrmp-absolute-x",
                                  "..\\..\\x", "C:/x"])
def test_a_registry_path_outside_out_is_refused(
    mirror: tuple[str, Path], tmp_path: Path, path: str
) -> None:
    url, split_dir = mirror
    _registry(split_dir, path)
    out = tmp_path / "a" / "b" / "out"
    with pytest.raises(DownloadError, match=r"expected a path inside|'<part>/<file>'"):
        download(SPLIT, out, base_url=url)
    assert not (tmp_path / "a" / "x").exists() and not (tmp_path / "x").exists()
    assert not Path("/tmp/nsrmp-absolute-x").exists()


def test_a_link_in_out_leading_outside_is_refused(
    mirror: tuple[str, Path], tmp_path: Path
) -> None:
    url, split_dir = mirror
    _registry(split_dir, "test/shard.h5")
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    out = tmp_path / "out"
    out.mkdir()
    (out / "test").symlink_to(outside, target_is_directory=True)
    with pytest.raises(DownloadError, match=r"leads outside through a link"):
        download(SPLIT, out, base_url=url)
    assert not any(outside.iterdir())


def test_an_existing_file_that_differs_is_kept_unless_overwrite(
    mirror: tuple[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    url, split_dir = mirror
    _registry(split_dir, "test/shard.h5")
    out = tmp_path / "out"
    (out / "test").mkdir(parents=True)
    mine = out / "test" / "shard.h5"
    mine.write_bytes(b"my own work\n")
    argv = ["download", "--split", SPLIT, "--out", str(out), "--base-url", url, "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "exists and differs" in err and "--overwrite" in err and "Traceback" not in err
    assert mine.read_bytes() == b"my own work\n"
    assert main([*argv, "--overwrite"]) == 0
    assert mine.read_bytes() == PAYLOAD


def test_an_existing_registry_txt_in_out_is_left_alone(
    mirror: tuple[str, Path], tmp_path: Path
) -> None:
    url, split_dir = mirror
    _registry(split_dir, "test/shard.h5")
    out = tmp_path / "out"
    out.mkdir()
    (out / "registry.txt").write_text("mine\n")
    download(SPLIT, out, base_url=url)
    assert (out / "registry.txt").read_text() == "mine\n"
    assert (out / "test" / "shard.h5").read_bytes() == PAYLOAD
