"""Absurd inputs get a sentence and exit 2, never a traceback or an unbounded run: a program
index of 2**70, a split spec whose part counts 10^12 instances, a secret of one letter."""

from __future__ import annotations

import gzip
import json
import secrets
import time
from pathlib import Path

import pytest

from nsrmp_bench.cli.main import main
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.private_parts import MIN_SECRET_BITS, check_secret, secret_bits

REPO = Path(__file__).resolve().parents[2]
ORACLE = REPO / "leaderboards" / "predictions" / "smoke-v2-test--oracle-v1.jsonl.gz"


def test_a_program_index_of_2_to_the_70_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lines = gzip.decompress(ORACLE.read_bytes()).decode().splitlines()
    record = json.loads(lines[1])
    record["program"] = [["top", 2**70, 0]]
    bad = tmp_path / "big.jsonl"
    bad.write_text("\n".join([lines[0], json.dumps(record), *lines[2:]]) + "\n")
    assert main(["check-submission", str(bad), "--split", "smoke-v2/test"]) == 2
    err = capsys.readouterr().err
    assert f"program[0] subject {2**70} must be an object index" in err
    assert "Traceback" not in err and "OverflowError" not in err


def test_info_on_a_spec_of_10_to_the_12_instances_counts_without_enumerating(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = json.loads((REPO / "splits" / "smoke-v2.json").read_text())
    spec["id"] = "huge-v1"
    for part in spec["parts"].values():
        part["count"] = 10**12
    path = tmp_path / "huge.json"
    path.write_text(json.dumps(spec))
    start = time.perf_counter()
    assert main(["info", "--spec", str(path)]) == 0
    assert time.perf_counter() - start < 30
    out = capsys.readouterr().out
    assert "1000000000000 instances" in out and "312500000000" in out


def test_a_secret_of_one_letter_or_a_short_pattern_is_refused() -> None:
    for weak in ("a" * 32, "ab" * 32, "0123456789abcdef" * 2):
        with pytest.raises(InvalidArgument, match=r"bits of entropy .* draw it at random"):
            check_secret(weak, "a test")
    strong = secrets.token_hex(16)
    assert secret_bits(strong) >= MIN_SECRET_BITS and check_secret(strong, "x") == strong
