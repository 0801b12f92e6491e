"""Malformed predictions files: each problem is one SubmissionError naming the line, the
value and the fix (or, where safe, a counted warning); nothing is dropped silently."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scoring_factory import HEADER, SPLIT, boxed_episode

from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import SubmissionError
from nsrmp_bench.scoring import check_submission, read_submission, score, write_submission
from nsrmp_bench.scoring.gold import GoldTable
from nsrmp_bench.scoring.submission import Prediction, SubmissionHeader
from nsrmp_bench.scoring.validate import MAX_SHOWN

INITIAL = [[100, 100, 120, 120], [200, 100, 220, 120], [50, 50, 70, 70]]
FINAL = [[100, 100, 120, 120], [100, 85, 120, 105], [50, 50, 70, 70]]


@pytest.fixture(scope="module")
def gold() -> GoldTable:
    eps: list[Episode] = [
        boxed_episode("e0", [INITIAL, FINAL], [("top", 1, 0)]),
        boxed_episode("e1", [INITIAL, FINAL, FINAL], [("top", 1, 0), ("left", 2, 1)]),
    ]
    return GoldTable.from_episodes(eps, split=SPLIT)


def header_line(**changes: Any) -> str:
    h = HEADER.to_dict()
    h.update(changes)
    return json.dumps({"header": h})


def good(eid: str = "e0", **changes: Any) -> dict[str, Any]:
    rec: dict[str, Any] = {"id": eid, "boxes": FINAL, "program": [["top", 1, 0]]}
    rec.update(changes)
    return rec


def write(tmp_path: Path, lines: list[str | dict[str, Any]], name: str = "p.jsonl") -> Path:
    p = tmp_path / name
    text = [x if isinstance(x, str) else json.dumps(x) for x in lines]
    p.write_text("\n".join(text) + "\n", encoding="utf-8")
    return p


def problem(path: Path, gold: GoldTable, *matches: str, **kw: Any) -> str:
    with pytest.raises(SubmissionError) as info:
        score(path, gold, n_boot=0, **kw)
    text = str(info.value)
    for m in matches:
        assert m in text, f"{m!r} not in:\n{text}"
    assert "Traceback" not in text
    return text


def test_a_valid_file_scores(tmp_path: Path, gold: GoldTable) -> None:
    p = write(tmp_path, [header_line(), good("e0"), good("e1", program=[["top", 1, 0]])])
    r = score(p, gold, n_boot=0)
    assert r.counts["predicted"] == 2 and r.counts["missing"] == 0


@pytest.mark.parametrize(
    ("lines", "matches"),
    [
        ([good("e0")], ["line 1", "first line must be the header", "a prediction"]),
        ([header_line(split="paper-v2"), good()], ["split 'paper-v2'", f"split {SPLIT!r}"]),
        ([header_line(scorer="scorer-v9"), good()], ["line 1", "'scorer-v9'", "scorer-v1"]),
        ([header_line(format_version="2.0.0"), good()], ["line 1", "'2.0.0'", "version 1.x"]),
        ([header_line(format="other"), good()], ["line 1", "format is 'other'"]),
        ([header_line(split=""), good()], ["line 1", "'split' must be a non-empty string"]),
        ([header_line(), "{not json"], ["line 2", "not valid JSON"]),
        ([header_line(), "[1, 2]"], ["line 2", "JSON array", "each line after the header"]),
        ([header_line(), header_line()], ["line 2", "second header"]),
        ([header_line(), good(box=[1])], ["line 2", "unknown field", "did you mean 'boxes'"]),
        ([header_line(), {"boxes": FINAL}], ["line 2", "'id' must be the instance id"]),
        ([header_line(), {"id": 7, "boxes": FINAL}], ["line 2", "'id' must be", "7"]),
        ([header_line(), {"id": "e0"}], ["line 2", "'boxes' is missing"]),
        ([header_line(), good(), good()], ["line 3", "'e0' was already given on line 2"]),
        ([header_line(), good(boxes=FINAL[:2])], ["line 2", "has 2 boxes", "has 3 objects"]),
        ([header_line(), good(boxes="x")], ["line 2", "'boxes' must be a list"]),
        ([header_line(), good(boxes=[[1, 2, 3]] * 3)], ["line 2", "boxes[0] must be a list of 4"]),
        ([header_line(), good(boxes=[[1, 2, 3, "4"]] * 3)], ["line 2", "boxes[0][3]", "string"]),
        ([header_line(), good(boxes=[[1, 2, 3, None]] * 3)], ["line 2", "boxes[0][3]", "null"]),
        ([header_line(), good(boxes=[[1, 2, 3, True]] * 3)], ["line 2", "boxes[0][3]", "boolean"]),
        ([header_line(), good(boxes=[[1, 2, 3, 10**30]] * 3)], ["line 2", "too large"]),
        ([header_line(), good(boxes=[[30, 2, 10, 4], *FINAL[1:]])],
         ["line 2", "boxes[0]", "x2 < x1", "swap"]),
        ([header_line(), good(boxes=[[0, 0, 500, 10], *FINAL[1:]])],
         ["line 2", "boxes[0]", "outside the 320x240 image", "normalised"]),
        ([header_line(), good(program=[["up", 1, 0]])], ["line 2", "'up'", "'top'"]),
        ([header_line(), good(program=[["top", 3, 0]])], ["line 2", "subject 3", "0..2"]),
        ([header_line(), good(program=[["top", 1.0, 0]])], ["line 2", "subject 1.0"]),
        ([header_line(), good(program=[["top", 1]])], ["line 2", "[action, subject, reference]"]),
        ([header_line(), good(program="top")], ["line 2", "'program' must be a list"]),
        ([header_line(), good(pick=[1])], ["line 2", "'pick' must be a pixel location"]),
        ([header_line(), good(pick=[1, 999])], ["line 2", "pick", "outside"]),
        ([header_line(), good(positions=[[0, 0]] * 3)], ["line 2", "positions[0]"]),
        ([header_line(), good(step_boxes=[FINAL[:1]])], ["line 2", "step_boxes[0]", "has 1"]),
        ([header_line(), good("nope")], ["line 2", "'nope' is not an instance of", "remove"]),
    ],
)
def test_each_problem_names_its_line(
    tmp_path: Path, gold: GoldTable, lines: list[Any], matches: list[str]
) -> None:
    problem(write(tmp_path, lines), gold, *matches)


def test_nan_and_infinity(tmp_path: Path, gold: GoldTable) -> None:
    nan_line = '{"id": "e0", "boxes": [[1, 2, NaN, 4], [1, 2, 3, 4], [1, 2, 3, 4]]}'
    inf_line = '{"id": "e1", "boxes": [[1, 2, 3, 4], [1, 2, 3, Infinity], [1, 2, 3, 4]]}'
    text = problem(write(tmp_path, [header_line(), nan_line, inf_line]), gold)
    assert "line 2: boxes[0]" in text and "line 3: boxes[1]" in text
    assert "NaN or infinite" in text and "2 problems" in text


def test_every_problem_is_listed_and_counted(tmp_path: Path) -> None:
    many = GoldTable.from_episodes(  # a line per instance at most: a part of 25 instances
        [boxed_episode(f"g{i}", [INITIAL, FINAL], [("top", 1, 0)]) for i in range(MAX_SHOWN + 5)],
        split=SPLIT)
    lines: list[Any] = [header_line()]
    lines += [good(f"x{i}") for i in range(MAX_SHOWN + 5)]
    text = problem(write(tmp_path, lines), many, f"{MAX_SHOWN + 5} problems", "and 5 more")
    assert text.count("is not an instance of") == MAX_SHOWN


def test_empty_and_missing_files(tmp_path: Path, gold: GoldTable) -> None:
    problem(write(tmp_path, []), gold, "holds no lines")
    with pytest.raises(SubmissionError, match="does not exist"):
        score(tmp_path / "absent.jsonl", gold, n_boot=0)
    with pytest.raises(SubmissionError, match="is a directory"):
        score(tmp_path, gold, n_boot=0)


def test_not_utf8(tmp_path: Path, gold: GoldTable) -> None:
    p = tmp_path / "bin.jsonl"
    p.write_bytes(header_line().encode() + b"\n\xff\xfe{}\n")
    problem(p, gold, "line 2", "not UTF-8")


def test_unknown_ids_can_be_counted_instead(tmp_path: Path, gold: GoldTable) -> None:
    p = write(tmp_path, [header_line(), good("e0"), good("stray"), good("other")])
    r = score(p, gold, n_boot=0, unknown_ids="warn")
    assert r.counts["unknown_ids_ignored"] == 2
    assert r.counts["predicted"] == 1 and r.counts["missing"] == 1
    assert any("2 line(s) with ids not in unit-v1 were ignored: line 3, line 4" in w
               for w in r.warnings)


def test_slightly_outside_is_clipped_and_counted(tmp_path: Path, gold: GoldTable) -> None:
    boxes = [[-0.5, 100, 120, 120.0], FINAL[1], [50, 50, 70, 240.8]]
    p = write(tmp_path, [header_line(), good(boxes=boxes, place=[320.5, 3])])
    r = score(p, gold, n_boot=0)
    assert r.counts["clipped"] == 3
    assert any("were clipped" in w for w in r.warnings)
    # Scored on the clipped boxes [0, 100, 120, 120] and [50, 50, 70, 240].
    expected = (400 / 2400 + 1 + 400 / 3800) / 3
    assert r.per_instance.at["e0", "iou"] == pytest.approx(expected)


def test_blank_lines_are_ignored(tmp_path: Path, gold: GoldTable) -> None:
    p = write(tmp_path, ["", header_line(), "", good("e0"), "   "])
    assert score(p, gold, n_boot=0).counts["predicted"] == 1


def test_data_without_split_id_is_noted(tmp_path: Path) -> None:
    eps = [boxed_episode("e0", [INITIAL, FINAL], [("top", 1, 0)])]
    p = write(tmp_path, [header_line(), good("e0")])
    r = score(p, eps, n_boot=0)
    assert any("records no split id" in w for w in r.warnings)


def test_check_submission(tmp_path: Path, gold: GoldTable) -> None:
    p = write(tmp_path, [header_line(), good("e0"), good("zz")])
    report = check_submission(p, split=SPLIT)
    assert report.lines == 2 and not report.against_data
    assert "were not checked" in report.summary()
    with pytest.raises(SubmissionError, match="checking it for split 'paper-v2'"):
        check_submission(p, split="paper-v2")
    with pytest.raises(SubmissionError, match="'zz' is not an instance"):
        check_submission(p, split=SPLIT, data=gold)
    ok = write(tmp_path, [header_line(), good("e0")], "ok.jsonl")
    report = check_submission(ok, split=SPLIT, data=gold)
    assert report.counts["missing"] == 1 and "1 missing" in report.summary()


def test_parquet_round_trip_scores_like_jsonl(tmp_path: Path, gold: GoldTable) -> None:
    pytest.importorskip("pyarrow")
    preds = [
        Prediction("e0", np.array(FINAL), program=None, pick=(110.0, 95.0)),
        Prediction("e1", np.array(FINAL), step_boxes=np.array([FINAL, FINAL]),
                   positions=np.zeros((3, 3))),
    ]
    from nsrmp_bench.dsl.program import GroundedStep

    preds[0] = Prediction("e0", np.array(FINAL), program=(GroundedStep("top", 1, 0),))
    a = score(write_submission(tmp_path / "p.jsonl", HEADER, preds), gold, n_boot=0)
    b = score(write_submission(tmp_path / "p.parquet", HEADER, preds), gold, n_boot=0)
    assert a.per_instance.equals(b.per_instance)
    assert read_submission(tmp_path / "p.parquet").line_label == "row"


def test_parquet_problems_name_rows(tmp_path: Path, gold: GoldTable) -> None:
    pytest.importorskip("pyarrow")
    preds = [Prediction("e0", np.array([[30, 2, 10, 4], *FINAL[1:]]))]
    path = write_submission(tmp_path / "bad.parquet", HEADER, preds)
    problem(path, gold, "row 1: boxes[0]", "x2 < x1")
    (tmp_path / "junk.parquet").write_bytes(b"not parquet")
    problem(tmp_path / "junk.parquet", gold, "not a readable Parquet file")
    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(pa.table({"id": ["e0"]}), tmp_path / "nohead.parquet")
    problem(tmp_path / "nohead.parquet", gold, "no 'nsrmp_bench.header' key")


def test_other_split_from_python(gold: GoldTable) -> None:
    from nsrmp_bench.scoring import parse_predictions

    sub = parse_predictions(SubmissionHeader(split="smoke-v2"),
                                      [Prediction("e0", np.array(FINAL))])
    with pytest.raises(SubmissionError, match="header says split 'smoke-v2'"):
        score(sub, gold, n_boot=0)


def test_split_of_a_part(tmp_path: Path) -> None:
    eps = [boxed_episode("e0", [INITIAL, FINAL], [("top", 1, 0)])]
    gold = GoldTable.from_episodes(eps, split=f"{SPLIT}/test")
    for declared in (SPLIT, f"{SPLIT}/test"):
        p = write(tmp_path, [header_line(split=declared), good("e0")], f"{declared[-4:]}.jsonl")
        assert score(p, gold, n_boot=0).counts["predicted"] == 1
        assert check_submission(p, split=SPLIT).lines == 1
    p = write(tmp_path, [header_line(split=f"{SPLIT}/val"), good("e0")], "val.jsonl")
    problem(p, gold, "header says split 'unit-v1/val'", "data is split 'unit-v1/test'")


def test_writing_a_non_finite_prediction_names_it(tmp_path: Path) -> None:
    from nsrmp_bench.errors import InvalidArgument

    bad = Prediction("e0", np.array([[0, 0, np.nan, 1]]))
    with pytest.raises(InvalidArgument, match="prediction 'e0': boxes holds NaN"):
        write_submission(tmp_path / "x.jsonl", HEADER, [bad])
    assert not (tmp_path / "x.jsonl").exists() and not (tmp_path / "x.jsonl.tmp").exists()
    with pytest.raises(InvalidArgument, match="positions must hold numbers"):
        Prediction("e0", np.zeros((1, 4)), positions=[["a", 1, 2]]).to_record()  # type: ignore[arg-type]


def test_step_boxes_for_another_step_count_are_ignored_and_counted(
    tmp_path: Path, gold: GoldTable
) -> None:
    """A model that splits an instruction into more steps than the gold cannot be scored
    step by step; its file still scores, those steps count as failures."""
    p = write(tmp_path, [header_line(), good(step_boxes=[FINAL, FINAL]),
                         good("e1", program=[["top", 1, 0], ["left", 2, 1]],
                              step_boxes=[FINAL, FINAL])])
    res = score(p, gold, n_boot=0)
    assert res.counts["step_boxes_other_step_count"] == 1
    assert res.counts["with_step_boxes"] == 1
    assert res.value("iou_m") == pytest.approx(1.0)
