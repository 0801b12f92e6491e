"""The bulk reader (msgspec + numpy, pyarrow where installed) gives the line-by-line
parser's table bit for bit on valid files, and hands every unusual file to that parser
(whose messages the malformed-file tests check)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scoring_factory import HEADER, synthetic_tables, write_table_jsonl

from nsrmp_bench.scoring import bulk as bulk_module
from nsrmp_bench.scoring.bulk import (
    numbers_arrow,
    numbers_numpy,
    read_jsonl_bulk,
    read_parquet_bulk,
)
from nsrmp_bench.scoring.reader import _read_jsonl, read_submission
from nsrmp_bench.scoring.submission import Submission


def line_by_line(path: Path) -> Submission:
    return _read_jsonl(path, path.read_bytes()).finish()


def assert_same(a: Submission, b: Submission) -> None:
    for name in Submission.__dataclass_fields__:
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray):
            assert isinstance(y, np.ndarray), name
            assert (x.dtype, x.shape) == (y.dtype, y.shape), name
            assert x.tobytes() == y.tobytes(), name  # bit for bit, NaN and -0.0 included
        else:
            assert x == y, name


def _no_pyarrow(text: bytes, width: int = 1) -> Any:
    """``numbers_arrow`` as on the core install, without pyarrow."""
    raise ImportError("pyarrow")


def bulk(path: Path) -> Submission:
    sub = read_jsonl_bulk(str(path), path.read_bytes())
    assert sub is not None, "the bulk reader left a valid file to the line-by-line parser"
    return sub


def test_synthetic_split_reads_the_same(tmp_path: Path) -> None:
    gold, pred = synthetic_tables(np.random.default_rng(3), 400)
    path = tmp_path / "pred.jsonl"
    write_table_jsonl(gold, pred, path)
    assert_same(bulk(path), line_by_line(path))


def _record(rng: np.random.Generator, k: int) -> dict[str, Any]:
    """A valid line using every optional field in some lines, with ints, floats,
    exponents and explicit nulls."""
    n = int(rng.integers(1, 6))
    xy = rng.uniform(0, 300, (n, 2))
    boxes = np.concatenate([xy, xy + rng.uniform(0, 20, (n, 2))], axis=1)
    rec: dict[str, Any] = {"id": f"inst-{k:04d}", "boxes": boxes.round(int(k % 5)).tolist()}
    if k % 3 == 0:
        rec["boxes"][0] = [int(v) for v in boxes[0].round()]
    if k % 4:
        rec["program"] = [[["top", "left", "right"][s % 3], s % n, (s + 1) % n]
                          for s in range(k % 3)]
    else:
        rec["program"] = None
    if k % 5 == 1:
        rec["step_boxes"] = [rec["boxes"]] * int(k % 3)
    if k % 7 == 2:
        rec["positions"] = rng.normal(0, 1e-3, (n, 3)).tolist()
    if k % 2:
        rec["pick"] = [1e1, float(k)]
        rec["place"] = None if k % 3 else [k, 2.5e-3]
    return rec


@pytest.mark.parametrize("separators", [(",", ":"), (", ", ": ")])
def test_every_field_reads_the_same(tmp_path: Path, separators: tuple[str, str]) -> None:
    rng = np.random.default_rng(1)
    lines = [json.dumps({"header": HEADER.to_dict()})]
    lines += [json.dumps(_record(rng, k), separators=separators) for k in range(300)]
    path = tmp_path / "pred.jsonl"
    path.write_text("\r\n".join(lines), encoding="utf-8")  # CRLF, no final newline
    assert_same(bulk(path), line_by_line(path))


def test_without_pyarrow_every_field_reads_the_same(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """The core install (no pyarrow) reads the numbers with numpy: the same table."""
    rng = np.random.default_rng(4)
    lines = [json.dumps({"header": HEADER.to_dict()})]
    lines += [json.dumps(_record(rng, k)) for k in range(200)]
    path = tmp_path / "pred.jsonl"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    expected = line_by_line(path)
    monkeypatch.setattr(bulk_module, "numbers_arrow", _no_pyarrow)
    assert_same(bulk(path), expected)


def test_parquet_reads_the_same_as_row_by_row(tmp_path: Path) -> None:
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    from nsrmp_bench.scoring.reader import _read_parquet
    from nsrmp_bench.scoring.submission import _parquet_table

    rng = np.random.default_rng(2)
    records = [_record(rng, k) for k in range(200)]
    for r in records:
        r["boxes"][0] = [float(v) for v in r["boxes"][0]]
    table = _parquet_table(pa, HEADER, records)
    path = tmp_path / "pred.parquet"
    pq.write_table(table, path)
    fast = _read_parquet(path)
    assert isinstance(fast, Submission)
    header = fast.header
    assert read_parquet_bulk(str(path), table.slice(0, 0), header) is None  # no rows
    slow = _read_parquet_row_by_row(path)
    assert_same(fast, slow)
    jsonl = tmp_path / "pred.jsonl"
    jsonl.write_text("\n".join([json.dumps({"header": HEADER.to_dict()}),
                                *map(json.dumps, records)]) + "\n")
    from_json = read_submission(jsonl)
    for name in ("boxes", "step_boxes", "positions", "pick", "place", "actions", "subjects"):
        assert getattr(from_json, name).tobytes() == getattr(fast, name).tobytes(), name


def _read_parquet_row_by_row(path: Path) -> Submission:
    """The Parquet rows through the line-by-line parser (what the reader falls back to)."""
    import pyarrow.parquet as pq

    from nsrmp_bench.scoring.validate import SubmissionParser

    table = pq.read_table(path)
    parser = SubmissionParser(str(path), line_label="row")
    header = json.loads(table.schema.metadata[b"nsrmp_bench.header"])
    parser.parse_header(None, {"header": header})
    for row, record in enumerate(table.to_pylist(), 1):
        rec = {k: v for k, v in record.items() if v is not None}
        if rec.get("program") is not None:
            rec["program"] = [[s["action"], s["subject"], s["reference"]] for s in rec["program"]]
        parser.parse_record(row, rec)
    return parser.finish()


def test_optional_fields_that_are_all_empty_read_the_same(tmp_path: Path) -> None:
    lines = [json.dumps({"header": HEADER.to_dict()})]
    lines += [json.dumps({"id": f"e{k}", "boxes": [[1, 2, 3, 4]], "step_boxes": [],
                          "program": []}) for k in range(3)]
    path = tmp_path / "pred.jsonl"
    path.write_text("\n".join(lines) + "\n")
    assert_same(bulk(path), line_by_line(path))


NUMBERS = ["0", "1", "-1", "0.1", "-0.5", "1e5", "1E-7", "2.5e+3", "123456.789012345",
           "5e-324", "1.7976931348623157e308", "9007199254740992", "0.30000000000000004",
           "3.141592653589793", "100", "-2.2250738585072014e-308"]


def test_both_number_readers_round_as_json_does() -> None:
    text = "".join(f"{v}\n" for v in NUMBERS).encode()
    expected = np.array([float(json.loads(v)) for v in NUMBERS])
    assert numbers_numpy(text).tobytes() == expected.tobytes()
    pytest.importorskip("pyarrow")
    assert numbers_arrow(text).tobytes() == expected.tobytes()


GOOD = '{"id": "e0", "boxes": [[1, 2, 3, 4]]}'


@pytest.mark.parametrize(
    "body",
    [
        [GOOD, "", '{"id": "e1", "boxes": [[1, 2, 3, 4]]}'],  # a blank line moves line numbers
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]]} {"id": "e1", "boxes": [[1, 2, 3, 4]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, true]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, null]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, NaN]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 1e400]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 10000000000000000000000000000]]}'],
        ['{"id": "e0", "boxes": [[-0, 2, 3, 4]]}'],  # json reads the int -0 as +0.0
        ['{"id": "e0", "boxes": [[3, 2, 1, 4]]}'],  # x2 < x1
        ['{"id": "e0", "boxes": [[1, 2, 3]]}'],
        ['{"id": "e0", "boxes": [[[1, 2, 3, 4]]]}'],
        ['{"id": "e0", "boxes": [1, [2, 3, 4, 5]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4], 5]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4], 5, [1, 2, 3, 4]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4, 5]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4], []]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "step_boxes": [[[1, 2, 3, 4]], [1, 2, 3, 4]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "step_boxes": [[[1, 2, 3, 4]], [[]]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "pick": [[1, 2]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "pick": 5}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "pick": [1, "2"]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "pick": [1, -0]}'],
        ['{"id": "e0", "boxes": [["1", 2, 3, 4]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4], [1, 2, 3, 4, [5]]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4], [5]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "step_boxes": [[[1, 2, 3, 4]], 5]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "step_boxes": [[[1, 2, 3, 4], 5]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "step_boxes": [5]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "step_boxes": [[5]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "step_boxes": [[[1, 2, 3, 4]]], "pick": [5]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "positions": [[1, 2, 3], [4, 5, 6]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "positions": [[1, 2, 3, {}]]}'],
        ['{"id": "e0", "boxes": []}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "step_boxes": [[]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "positions": [[1, 2]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "pick": [1, 2, 3]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "program": [["up", 0, 0]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "program": [["top", 1, 0]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "program": [["top", 0.0, 0]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "detections": [[1, 2, 3, 4]]}'],
        ['{"id": "e0", "boxes": [[1, 2, 3, 4]], "box": 1}'],
        [GOOD, GOOD],  # the same id twice
        ['{"id": "", "boxes": [[1, 2, 3, 4]]}'],
        ['[1, 2]'],
    ],
)
@pytest.mark.parametrize("numbers", ["pyarrow", "numpy"])
def test_unusual_files_go_line_by_line(tmp_path: Path, body: list[str], numbers: str,
                                       monkeypatch: pytest.MonkeyPatch) -> None:
    if numbers == "numpy":
        monkeypatch.setattr(bulk_module, "numbers_arrow", _no_pyarrow)
    path = tmp_path / "p.jsonl"
    path.write_text("\n".join([json.dumps({"header": HEADER.to_dict()}), *body]) + "\n")
    assert read_jsonl_bulk(str(path), path.read_bytes()) is None


@pytest.mark.parametrize("first", ["", GOOD, '{"header": {"format": "other"}}', "{not json"])
def test_a_file_without_a_valid_first_header_goes_line_by_line(tmp_path: Path,
                                                                first: str) -> None:
    path = tmp_path / "p.jsonl"
    path.write_text("\n".join([first, json.dumps({"header": HEADER.to_dict()}), GOOD]) + "\n")
    assert read_jsonl_bulk(str(path), path.read_bytes()) is None
