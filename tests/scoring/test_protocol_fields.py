"""Protocol fields: every committed leaderboard entry and its predictions header state them
truly (the script that writes them finds nothing to change, and each root hash is its
part's committed one);
`baseline` writes them into the header; `check-submission` checks them, refusing a file
made on another manifest and a malformed field with the fix; the leaderboard refuses an
entry whose protocol names another part."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from nsrmp_bench.errors import InvalidArgument, SubmissionError
from nsrmp_bench.leaderboard import build, load_entries
from nsrmp_bench.official_manifests import official_manifest
from nsrmp_bench.scoring.check import check_submission
from nsrmp_bench.scoring.protocol_fields import PROTOCOL_KEYS, ProtocolFields
from nsrmp_bench.scoring.reader import read_header
from nsrmp_bench.storage.manifest import read_manifest

REPO = Path(__file__).resolve().parents[2]
ENTRIES = REPO / "leaderboards" / "entries"


def test_every_committed_entry_states_its_protocol_truly() -> None:
    entries = load_entries(ENTRIES)
    assert len(entries) >= 80
    for entry in entries:
        assert entry.protocol is not None, entry.name
        split_id, _, part = entry.split.partition("/")
        committed = official_manifest(split_id, part)
        assert committed is not None
        assert entry.protocol.manifest_root_hash == committed["root_hash"], entry.name
        detector = entry.model.partition("+")[2]
        assert entry.protocol.boxes == (f"detected:{detector}" if detector else "gold")
        if entry.kind == "baseline":
            assert entry.protocol.training_parts == ()
        header = read_header(entry.predictions)
        assert header["protocol"] == entry.protocol.to_dict(), entry.name
    done = subprocess.run([sys.executable, str(REPO / "scripts" / "protocol_fields.py"),
                           "--check"], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stdout + done.stderr


def _lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def _write(path: Path, lines: list[dict[str, Any]]) -> Path:
    path.write_text("".join(json.dumps(line) + "\n" for line in lines))
    return path


@pytest.fixture(scope="module")
def noop(smoke_v2_test: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("protocol") / "noop.jsonl"
    done = subprocess.run([sys.executable, "-m", "nsrmp_bench.cli.main", "baseline", "noop",
                           "--data", str(smoke_v2_test), "--out", str(out)],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    return out


@pytest.mark.sim
def test_the_baseline_header_states_the_protocol_and_check_submission_accepts_it(
        noop: Path, smoke_v2_test: Path) -> None:
    protocol = _lines(noop)[0]["header"]["protocol"]
    assert list(protocol) == list(PROTOCOL_KEYS)
    assert protocol["manifest_root_hash"] == read_manifest(smoke_v2_test).root_hash
    assert protocol["training_parts"] == [] and protocol["seeds"] == []
    with_data = check_submission(noop, split="smoke-v2/test", data=smoke_v2_test)
    assert "made on the manifest of smoke-v2/test" in with_data.summary()
    committed = check_submission(noop, split="smoke-v2/test")  # the committed manifest
    assert "made on the manifest of smoke-v2/test" in committed.summary()


@pytest.mark.sim
def test_a_file_made_on_another_manifest_is_refused(noop: Path, smoke_v2_test: Path,
                                                   tmp_path: Path) -> None:
    lines = _lines(noop)
    lines[0]["header"]["protocol"]["manifest_root_hash"] = "ab" * 32
    other = _write(tmp_path / "other.jsonl", lines)
    for data in (smoke_v2_test, None):
        with pytest.raises(SubmissionError, match="made on another manifest") as exc:
            check_submission(other, split="smoke-v2/test", data=data)
        assert "abababababababab" in str(exc.value) and "predict again" in str(exc.value)


@pytest.mark.sim
@pytest.mark.parametrize(("key", "value", "expected"), [
    ("seeds", "zero", "a list of non-negative integers"),
    ("boxes", "mine", "'gold' or 'detected:<detector id>'"),
    ("training_parts", ["paper"], "a list of split parts"),
    ("manifest_root_hash", "123", "64 hex digits"),
    ("scorer", "scorer-v9", "one of ['scorer-v1', 'scorer-v2']"),
])
def test_a_malformed_protocol_field_is_named_with_the_fix(
        noop: Path, tmp_path: Path, key: str, value: Any, expected: str) -> None:
    lines = _lines(noop)
    lines[0]["header"]["protocol"][key] = value
    bad = _write(tmp_path / "bad.jsonl", lines)
    with pytest.raises(SubmissionError) as exc:
        check_submission(bad, split="smoke-v2/test")
    assert f"protocol field {key!r}" in str(exc.value) and expected in str(exc.value)


@pytest.mark.sim
def test_a_file_without_protocol_is_valid_with_a_warning(noop: Path, tmp_path: Path) -> None:
    lines = _lines(noop)
    del lines[0]["header"]["protocol"]
    bare = _write(tmp_path / "bare.jsonl", lines)
    report = check_submission(bare, split="smoke-v2/test")
    assert 'states no "protocol"' in report.summary()


def test_protocol_round_trips_and_refuses_missing_keys() -> None:
    fields = ProtocolFields("none", "gold", (), (), "scorer-v1", "0" * 64)
    assert ProtocolFields.from_dict(fields.to_dict(), "here") == fields
    partial = fields.to_dict()
    del partial["seeds"]
    with pytest.raises(InvalidArgument, match=r"lacks \['seeds'\]"):
        ProtocolFields.from_dict(partial, "here")


@pytest.mark.sim
def test_the_leaderboard_refuses_an_entry_made_on_another_part(
        smoke_v2_root: Path, tmp_path: Path) -> None:
    entries = tmp_path / "leaderboards" / "entries"
    entries.mkdir(parents=True)
    (entries.parent / "predictions").symlink_to(ENTRIES.parent / "predictions",
                                                target_is_directory=True)
    source = ENTRIES / "smoke-v2-test--noop-v1.json"
    data = json.loads(source.read_text())
    data["protocol"]["manifest_root_hash"] = "cd" * 32
    (entries / source.name).write_text(json.dumps(data))
    root = tmp_path / "data"
    root.mkdir()
    (root / "smoke-v2").symlink_to(smoke_v2_root, target_is_directory=True)
    with pytest.raises(InvalidArgument, match="made on another manifest"):
        build(entries, root, tmp_path / "out")
