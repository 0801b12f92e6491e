"""Reading a predictions file is bounded by its part: real bombs, made here, are refused the
moment they pass a bound, with a sentence and exit 2.

The files claim smoke-v2/test (16 instances, its manifest committed), so every bound is
the committed manifest's; none of these tests needs the split's data.
"""

from __future__ import annotations

import functools
import gzip
import json
import zlib
from pathlib import Path

import numpy as np
import pytest

from nsrmp_bench.cli.main import main
from nsrmp_bench.errors import SubmissionError
from nsrmp_bench.scoring.file_formats import read_jsonl_bounded
from nsrmp_bench.scoring.read_limits import HEADER_BYTES, ReadLimits
from nsrmp_bench.scoring.reader import limits_for, read_submission

REPO = Path(__file__).resolve().parents[2]
PREDICTIONS = REPO / "leaderboards" / "predictions"
HEADER = (json.dumps({"header": {"format": "nsrmp-bench-predictions", "format_version": "1.0.0",
                                 "split": "smoke-v2/test", "scorer": "scorer-v1"}})
          + "\n").encode()


@functools.lru_cache
def _member(filler: bytes) -> bytes:
    """One gzip member of 16 MiB of ``filler`` (16 kB)."""
    member = zlib.compressobj(9, zlib.DEFLATED, 31)
    return member.compress(filler * ((16 << 20) // len(filler))) + member.flush()


def gzip_bomb(path: Path, first: bytes, filler: bytes, members: int = 128) -> Path:
    """``first`` then gzip members of 16 MiB of ``filler`` each (128 members: a 2 MB file
    that decompresses to 2 GiB)."""
    path.write_bytes(gzip.compress(first, mtime=0) + _member(filler) * members)
    return path


def test_the_bounds_come_from_the_committed_manifest() -> None:
    limits = ReadLimits.committed("smoke-v2/test")
    assert limits is not None and limits.instances == 16 and limits.lines == 17
    assert HEADER_BYTES <= limits.line_bytes <= limits.file_bytes < 4 << 20
    assert ReadLimits.committed("nowhere-v9/test") is None


@pytest.mark.parametrize("filler", [b" ", b"\n", b"0"])
def test_a_gzip_bomb_is_refused_at_its_bound(tmp_path: Path, filler: bytes) -> None:
    bomb = gzip_bomb(tmp_path / "bomb.jsonl.gz", HEADER, filler)
    assert bomb.stat().st_size < 3 << 20
    limits = limits_for(bomb)
    with pytest.raises(SubmissionError, match=r"more than a file for the 16 instances of "
                                              r"smoke-v2/test can hold; reading stopped"):
        read_submission(bomb)
    with pytest.raises(SubmissionError, match=r"line longer|bytes of text"):
        read_jsonl_bounded(bomb, limits)


def test_a_bomb_is_refused_by_check_submission_with_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bomb = gzip_bomb(tmp_path / "bomb.jsonl.gz", HEADER, b"\n")
    assert main(["check-submission", str(bomb), "--split", "smoke-v2/test"]) == 2
    err = capsys.readouterr().err
    assert "reading stopped" in err and "Traceback" not in err


def test_more_lines_than_instances_are_refused(tmp_path: Path) -> None:
    lines = tmp_path / "many.jsonl"
    lines.write_bytes(HEADER + b'{"id": "x", "boxes": []}\n' * 18)
    with pytest.raises(SubmissionError, match=r"more than 17 lines \(one per instance and the "
                                              r"header\)"):
        read_submission(lines)


def test_blank_lines_are_not_counted_but_their_bytes_are(tmp_path: Path) -> None:
    valid = gzip.decompress((PREDICTIONS / "smoke-v2-test--oracle-v1.jsonl.gz").read_bytes())
    spaced = tmp_path / "spaced.jsonl"
    spaced.write_bytes(valid.replace(b"\n", b"\n\n\r\n"))
    assert len(read_submission(spaced)) == 16


def test_a_header_over_its_bound_is_refused(tmp_path: Path) -> None:
    big = tmp_path / "big-header.jsonl"
    big.write_bytes(b'{"header": {"x": "' + b"a" * HEADER_BYTES + b'"}}\n')
    with pytest.raises(SubmissionError, match=r"first line \(the header\) is longer"):
        read_submission(big)


def test_every_committed_predictions_file_is_within_its_bounds() -> None:
    for path in sorted(PREDICTIONS.glob("smoke-v2-test--*")) + \
            sorted(PREDICTIONS.glob("paper-v2-test--*"))[:3]:
        read_jsonl_bounded(path, limits_for(path))


def test_a_parquet_bomb_is_refused_before_its_pages_are_read(tmp_path: Path) -> None:
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    n = 4_000_000  # boxes of one row: 16M zeros, a few kB on disk
    flat = pa.array(np.zeros(4 * n))
    boxes = pa.ListArray.from_arrays(pa.array([0, n], pa.int32()),
                                     pa.FixedSizeListArray.from_arrays(flat, 4).cast(
                                         pa.list_(pa.float64())))
    table = pa.table({"id": ["smoke-v2-test-000000"], "boxes": boxes})
    header = json.loads(HEADER)["header"]
    table = table.replace_schema_metadata({"nsrmp_bench.header": json.dumps(header)})
    bomb = tmp_path / "bomb.parquet"
    pq.write_table(table, bomb, compression="zstd")
    assert bomb.stat().st_size < 1 << 20
    with pytest.raises(SubmissionError, match=r"reading stopped before its pages"):
        read_submission(bomb)
