"""Gold is what its manifest says, and predictions are scored on the part they were made on.

On a copy of the generated smoke-v2/test: a shard whose bytes changed (same size) is
refused by ``score``, not scored; a file whose header protocol names another manifest is
refused by ``score`` as by ``check-submission``, unless ``--allow-other-manifest``.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest

from nsrmp_bench.baselines.registry import run_baseline
from nsrmp_bench.cli.main import main
from nsrmp_bench.errors import DataIntegrityError
from nsrmp_bench.scoring.gold import load_episodes
from nsrmp_bench.scoring.scorer import score
from nsrmp_bench.storage.manifest import read_manifest
from nsrmp_bench.storage.verified_files import file_identity, sha256_once

pytestmark = pytest.mark.sim


@pytest.fixture()
def part(smoke_v2_test: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "test"
    shutil.copytree(smoke_v2_test, copy)
    return copy


def _noop(part: Path, out: Path, root_hash: str | None = None) -> Path:
    episodes, split = load_episodes(part)
    return run_baseline("noop-v1", episodes, out, split=str(split),
                        manifest_root_hash=root_hash or read_manifest(part).root_hash)


def test_a_tampered_shard_of_the_same_size_is_refused(
    part: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    predictions = _noop(part, tmp_path / "noop.jsonl")
    shard = sorted(part.glob("shard-*.h5"))[0]
    score(predictions, part, n_boot=0)  # hashed once, remembered by identity
    data = bytearray(shard.read_bytes())
    data[len(data) // 2] ^= 0xFF
    shard.write_bytes(bytes(data))
    with pytest.raises(DataIntegrityError, match=r"has sha256 .* but the manifest says"):
        score(predictions, part, n_boot=0)
    assert main(["score", str(predictions), "--data", str(part), "--n-boot", "0"]) == 2
    err = capsys.readouterr().err
    assert "re-download or regenerate it" in err and "Traceback" not in err


def test_a_hash_is_remembered_by_file_identity(tmp_path: Path) -> None:
    f = tmp_path / "f.bin"
    f.write_bytes(b"a" * 100)
    assert sha256_once(f) == hashlib.sha256(b"a" * 100).hexdigest()
    before = file_identity(f)
    f.write_bytes(b"b" * 100)  # the same size, rewritten in place: another identity
    assert file_identity(f) != before
    assert sha256_once(f) == hashlib.sha256(b"b" * 100).hexdigest()


def test_score_refuses_another_manifest_unless_asked(
    part: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    other = _noop(part, tmp_path / "other.jsonl", root_hash="cd" * 32)
    argv = ["score", str(other), "--data", str(part), "--n-boot", "0", "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "made on another manifest" in err and "--allow-other-manifest" in err
    assert main(["check-submission", str(other), "--split", "smoke-v2/test",
                 "--data", str(part)]) == 2
    capsys.readouterr()
    assert main([*argv, "--allow-other-manifest"]) == 0
    same = _noop(part, tmp_path / "same.jsonl")
    assert main(["score", str(same), "--data", str(part), "--n-boot", "0", "--quiet"]) == 0
    header = json.loads(same.read_text().splitlines()[0])["header"]
    assert header["protocol"]["manifest_root_hash"] == read_manifest(part).root_hash


def test_check_submission_against_an_inputs_only_pack(
    part: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from nsrmp_bench.release import pack

    pack(part, tmp_path / "release", inputs_only=True)
    held = tmp_path / "release" / "smoke-v2" / "test"
    good = _noop(part, tmp_path / "noop.jsonl")
    assert main(["check-submission", str(good), "--split", "smoke-v2/test",
                 "--data", str(held)]) == 0
    assert "checked against the inputs-only pack" in capsys.readouterr().out
    lines = good.read_text().splitlines()
    record = json.loads(lines[1])
    record["boxes"][0] = [0.0, 0.0, 400.0, 10.0]
    outside = tmp_path / "outside.jsonl"
    outside.write_text("\n".join([lines[0], json.dumps(record), *lines[2:]]) + "\n")
    other = _noop(part, tmp_path / "other.jsonl", root_hash="cd" * 32)
    for bad, said in ((outside, "lies outside the"), (other, "made on another manifest")):
        assert main(["check-submission", str(bad), "--split", "smoke-v2/test",
                     "--data", str(held)]) == 2
        err = capsys.readouterr().err
        assert said in err and "Traceback" not in err
