"""verify, pack, download (from a local HTTP server), info and audit on generated data."""

from __future__ import annotations

import functools
import http.server
import shutil
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from nsrmp_bench.audit import audit, held_out_words
from nsrmp_bench.cli.main import main
from nsrmp_bench.errors import DownloadError
from nsrmp_bench.release import download, pack
from nsrmp_bench.storage.reader import open as open_data
from nsrmp_bench.verify import verify

pytestmark = pytest.mark.sim


@pytest.fixture()
def server(tmp_path: Path) -> Iterator[tuple[str, Path, list[str]]]:
    root = tmp_path / "mirror"
    root.mkdir()
    requests: list[str] = []

    class Handler(http.server.SimpleHTTPRequestHandler):
        def log_message(self, fmt: str, *args: object) -> None:
            requests.append(self.path)

    httpd = http.server.ThreadingHTTPServer(
        ("127.0.0.1", 0), functools.partial(Handler, directory=str(root))
    )
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}", root, requests
    finally:
        httpd.shutdown()
        httpd.server_close()


def test_verify_passes_then_names_a_tampered_episode(smoke_dir: Path, tmp_path: Path) -> None:
    report = verify(smoke_dir / "test")
    assert report.ok, report.problems
    assert report.episodes == 16
    copy = tmp_path / "copy"
    shutil.copytree(smoke_dir / "test", copy)
    shard = sorted(copy.glob("shard-*.h5"))[0]
    with open_data(copy) as data:
        victim = data.index["id"].iloc[0]
    import h5py

    with h5py.File(shard, "r+") as f:
        boxes = f["data"][victim]["targets"]["boxes_amodal"]
        boxes[0, 0, 0] = boxes[0, 0, 0] + 5.0
    report = verify(copy)
    assert not report.ok
    text = "\n".join(report.problems)
    assert shard.name in text and "sha256 differs" in text
    assert victim in text


def test_verify_says_whether_the_shard_files_are_the_committed_ones(
    smoke_dir: Path, tmp_path: Path
) -> None:
    """Generated as committed, with the nsrmp-bench and h5py the committed manifest records:
    the files too are the committed bytes (with others, verify must say they are not). The
    same episodes in shards of 8: verify passes (the episodes are the same) and says the
    files are not the committed ones."""
    import importlib.metadata

    from nsrmp_bench import __version__
    from nsrmp_bench.generators.generate import generate_split
    from nsrmp_bench.official_manifests import official_manifest

    committed = official_manifest("smoke-v2", "test")
    assert committed is not None
    recorded = committed["versions"]
    same_tools = (recorded.get("nsrmp-bench") == __version__
                  and recorded.get("h5py") == importlib.metadata.version("h5py"))
    report = verify(smoke_dir / "test")
    assert report.ok and report.identical_files == (1 if same_tools else report.identical_files)
    if report.identical_files == 1:
        assert "every shard file is byte for byte the committed one (1 shard)" in report.notes
    else:
        assert any(n.startswith("0 of 1 shard file here") for n in report.notes), report.notes
    generate_split("smoke-v2", tmp_path, workers=1, shard_size=8)
    report = verify(tmp_path / "test")
    assert report.ok and report.identical_files == 0
    assert report.root_hash == report.committed_root_hash
    assert any(n.startswith("0 of 2 shard files here are byte for byte the committed ones "
                            "(1 committed)") for n in report.notes), report.notes


def test_pack_and_download_verified_and_resumed(
    smoke_dir: Path, tmp_path: Path, server: tuple[str, Path, list[str]]
) -> None:
    url, root, requests = server
    entries = pack(smoke_dir, root)
    assert (root / "smoke-v2" / "registry.txt").is_file()
    assert {e.path.split("/")[0] for e in entries} == {"test"}
    out = tmp_path / "dl"
    download("smoke-v2", out, base_url=url, trust_mirror_registry=True)
    assert verify(out / "test").ok
    before = len(requests)
    download("smoke-v2", out, base_url=url, trust_mirror_registry=True)
    fetched_again = [r for r in requests[before:] if r.endswith(".h5")]
    assert not fetched_again, "files already present and correct must not be fetched again"


def test_download_refuses_a_corrupted_file(
    smoke_dir: Path, tmp_path: Path, server: tuple[str, Path, list[str]]
) -> None:
    url, root, _ = server
    pack(smoke_dir, root)
    shard = sorted((root / "smoke-v2" / "test").glob("shard-*.h5"))[0]
    data = bytearray(shard.read_bytes())
    data[len(data) // 2] ^= 0xFF
    shard.write_bytes(bytes(data))
    out = tmp_path / "dl"
    with pytest.raises(DownloadError, match=r"does not match the registry's sha256.*corrupted"):
        download("smoke-v2", out, base_url=url, trust_mirror_registry=True)
    assert not (out / "test" / shard.name).exists(), "a corrupted download must not be kept"


def test_download_without_mirror_says_what_to_do(tmp_path: Path) -> None:
    with pytest.raises(DownloadError, match=r"pass --base-url URL or set NSRMP_BENCH_MIRROR"):
        download("smoke-v2", tmp_path, base_url="")


def test_cli_info_audit_verify(smoke_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", str(smoke_dir / "test")]) == 0
    out = capsys.readouterr().out
    assert "16 instances" in out and "phrasing" in out
    assert main(["audit", str(smoke_dir)]) == 0
    assert "audit passed" in capsys.readouterr().out
    assert main(["verify", str(smoke_dir)]) == 0


def test_audit_fails_on_shared_instances(smoke_dir: Path) -> None:
    with open_data(smoke_dir / "test") as data:
        eps = [e.symbolic for e in data.iter_episodes(images=False)]
    leaked = [("smoke-v2", "test", e) for e in eps] + [("paper-v2", "test", eps[0])]
    from nsrmp_bench.generators.templates import load_language

    report = audit(leaked, held_out_words(load_language()))
    assert not report.ok
    assert report.shared["scenes"] == 1
    assert any("triples" in f for f in report.failures)


def test_official_download_uses_the_committed_manifest(
    smoke_dir: Path, tmp_path: Path, server: tuple[str, Path, list[str]]
) -> None:
    from nsrmp_bench.official_manifests import official_manifest

    if official_manifest("smoke-v2", "test") is None:
        pytest.skip("no committed manifest for smoke-v2")
    url, root, requests = server
    pack(smoke_dir, root)
    (root / "smoke-v2" / "registry.txt").write_text("not a registry\n")  # never read
    out = tmp_path / "official"
    download("smoke-v2", out, base_url=url)
    assert not any(r.endswith("registry.txt") for r in requests)
    report = verify(out / "test")
    assert report.ok, report.problems
    assert report.committed_root_hash == report.root_hash
    committed = (out / "test" / "manifest.json").read_text()
    (out / "test" / "manifest.json").write_text("{}\n")  # the user's own: kept unless asked
    with pytest.raises(DownloadError, match=r"differs from the committed manifest.*--overwrite"):
        download("smoke-v2", out, base_url=url)
    assert (out / "test" / "manifest.json").read_text() == "{}\n"
    download("smoke-v2", out, base_url=url, overwrite=True)
    assert (out / "test" / "manifest.json").read_text() == committed
