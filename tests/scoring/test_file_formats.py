"""Gzip-compressed JSON Lines predictions (``.jsonl.gz``): written and read back by the same
code as JSON Lines, scored the same, refused clearly when broken; the committed predictions
are stored so."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest

from nsrmp_bench.cli.main import main
from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.errors import InvalidArgument, SubmissionError
from nsrmp_bench.generators.sampler import sample_episode
from nsrmp_bench.leaderboard import load_entries
from nsrmp_bench.scoring import read_submission, score
from nsrmp_bench.scoring.file_formats import (
    PredictionsFormat,
    predictions_format,
    read_jsonl_bytes,
    written_format,
)
from nsrmp_bench.scoring.reader import read_header

REPO = Path(__file__).resolve().parents[2]
SPLIT = "gz-v1"


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Five symbolic episodes (no rendering needed to score)."""
    path = tmp_path_factory.mktemp("gz") / "episodes.jsonl"
    eps = [sample_episode(EpisodeConfig(objects=5, steps=2), 7, i, f"{SPLIT}-test-{i:06d}",
                          max_attempts=200) for i in range(5)]
    path.write_text("".join(json.dumps(e.to_dict()) + "\n" for e in eps), "utf-8")
    return path


def cli(*args: str | Path) -> int:
    return main([str(a) for a in args])


def test_a_compressed_file_holds_the_same_lines_and_scores_the_same(
        tmp_path: Path, data: Path) -> None:
    plain, packed = tmp_path / "random.jsonl", tmp_path / "random.jsonl.gz"
    for out in (plain, packed):
        assert cli("baseline", "random", "--data", data, "--out", out, "--split", SPLIT,
                   "--seed", "5") == 0
    assert packed.read_bytes()[:2] == b"\x1f\x8b"
    assert gzip.decompress(packed.read_bytes()) == plain.read_bytes()
    assert packed.stat().st_size < plain.stat().st_size
    a, b = read_submission(plain), read_submission(packed)
    assert a.ids == b.ids and (a.boxes == b.boxes).all()
    assert read_header(packed) == read_header(plain) == json.loads(
        plain.read_text().splitlines()[0])["header"]
    ra, rb = score(plain, data, n_boot=0), score(packed, data, n_boot=0)
    assert ra.summary.equals(rb.summary)
    # The same predictions make the same bytes (no time or file name in the gzip header).
    again = tmp_path / "later" / "random.jsonl.gz"
    assert cli("baseline", "random", "--data", data, "--out", again, "--split", SPLIT,
               "--seed", "5") == 0
    assert again.read_bytes() == packed.read_bytes()
    assert again.read_bytes()[3:8] == b"\0\0\0\0\0"  # no flags (no file name), mtime 0
    assert read_jsonl_bytes(again) == plain.read_bytes()


def test_a_broken_compressed_file_is_named_with_the_fix(tmp_path: Path, data: Path,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    plain, packed = tmp_path / "noop.jsonl", tmp_path / "noop.jsonl.gz"
    assert cli("baseline", "noop", "--data", data, "--out", plain, "--split", SPLIT) == 0
    not_gzip = tmp_path / "plain-named.jsonl.gz"
    not_gzip.write_bytes(plain.read_bytes())
    with pytest.raises(SubmissionError, match=r"plain-named\.jsonl\.gz.*not a complete gzip "
                       r"stream.*gzip -k FILE\.jsonl"):
        read_submission(not_gzip)
    packed.write_bytes(gzip.compress(plain.read_bytes())[:-20])
    with pytest.raises(SubmissionError, match="not a complete gzip stream"):
        read_submission(packed)
    assert cli("score", packed, "--data", data, "--split", SPLIT) == 2
    assert "not a complete gzip stream" in capsys.readouterr().err
    # A compressed file whose lines are wrong is told line by line, as a plain one.
    packed.write_bytes(gzip.compress(plain.read_bytes().replace(b'"boxes"', b'"bxes"', 1)))
    with pytest.raises(SubmissionError, match="line 2"):
        read_submission(packed)


def test_names_pick_the_format() -> None:
    assert predictions_format("p.jsonl.gz") is PredictionsFormat.JSONL_GZ
    assert predictions_format("p.parquet") is PredictionsFormat.PARQUET
    assert predictions_format("p.txt") is PredictionsFormat.JSONL  # reading is lenient
    assert written_format("a/p.JSONL.GZ") is PredictionsFormat.JSONL_GZ
    for bad in ("p.gz", "p.txt", "p.csv.gz", "p"):
        with pytest.raises(InvalidArgument, match=r"\.jsonl\.gz \(gzip-compressed JSON Lines\)"):
            written_format(bad)


def test_the_committed_predictions_are_compressed_with_a_fixed_header() -> None:
    entries = load_entries(REPO / "leaderboards" / "entries")
    files = sorted((REPO / "leaderboards" / "predictions").iterdir())
    assert {e.predictions.name for e in entries} == {f.name for f in files}
    for f in files:
        assert f.name.endswith(".jsonl.gz"), f.name
        head = f.read_bytes()[:10]
        # gzip magic, deflate, no flags (so no file name), modification time 0
        assert head[:8] == b"\x1f\x8b\x08\x00\0\0\0\0", f.name
        assert set(read_header(f)) >= {"format", "split", "scorer", "model"}, f.name
