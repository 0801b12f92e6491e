"""summary.json: the committed leaderboard runs read, round-trip to the same bytes, and
bad files are refused with the fix."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from site_build import BOARDS, SITE

from nsrmp_bench.errors import InvalidArgument, SchemaVersionError
from nsrmp_bench.results.summary import KEPT_METRICS, Results


def test_committed_summary_round_trips_to_the_same_bytes(tmp_path: Path) -> None:
    results = Results.read(SITE)
    assert results.runs
    written = results.write(tmp_path)
    assert written.read_bytes() == (SITE / "summary.json").read_bytes()


def test_summary_runs_agree_with_the_json_boards() -> None:
    results = Results.read(SITE)
    for board_file in BOARDS.glob("*.json"):
        board = json.loads(board_file.read_text())
        for row in board["rows"]:
            run = results.run(row["model"], board["split"])
            assert run is not None, (board["split"], row["model"])
            for metric, triple in row["metrics"].items():
                est = run.metric(metric)
                shown = tuple(None if math.isnan(v) else v for v in (est.value, est.low, est.high))
                assert shown == tuple(triple), (row["entry"], metric)
            assert run.metric("iou").n == row["n"]  # every instance (IoU-M: the moving ones)


def test_summary_keeps_the_breakdown_but_not_templates() -> None:
    run = Results.read(SITE).run("nsrm-v1", "paper-v2/test")
    assert run is not None
    categories = {c for c, _, _ in run.per_category}
    assert {"steps", "objects", "relational", "phrasing"} <= categories
    assert "template" not in categories
    assert {m for _, _, m in run.per_category} <= set(KEPT_METRICS)
    steps = dict(run.groups("steps", "iou_m"))
    assert sorted(steps) == ["1", "2"]
    total = sum(e.n for e in steps.values())
    assert total == run.metric("iou_m").n


def test_bad_summaries_name_the_fix(tmp_path: Path) -> None:
    with pytest.raises(InvalidArgument, match=r"does not exist; a results folder is written by"):
        Results.read(tmp_path)
    (tmp_path / "summary.json").write_text(json.dumps({"format": "other"}))
    with pytest.raises(InvalidArgument, match=r"not an nsrmp-bench results summary"):
        Results.read(tmp_path)
    data = json.loads((SITE / "summary.json").read_text())
    data["schema_version"] = "9.0.0"
    (tmp_path / "summary.json").write_text(json.dumps(data))
    with pytest.raises(SchemaVersionError, match=r"major version 9.*upgrade nsrmp-bench"):
        Results.read(tmp_path)
    data["schema_version"] = "1.0.0"
    data["runs"] = data["runs"][:1] * 2
    (tmp_path / "summary.json").write_text(json.dumps(data))
    with pytest.raises(InvalidArgument, match=r"is scored twice on"):
        Results.read(tmp_path)
