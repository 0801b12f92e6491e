"""The semantics board: every phenomenon's figures per row, on a real generated part."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from nsrmp_bench.leaderboard import PHENOMENON_COLUMNS, build
from nsrmp_bench.vocabulary import PHENOMENA

pytestmark = pytest.mark.sim

CLI = [sys.executable, "-m", "nsrmp_bench.cli.main"]


@pytest.fixture(scope="module")
def semantics_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("semantics")
    subprocess.run([*CLI, "generate", "--split", "semantics-v1", "--part", "test", "--limit",
                    "18", "--workers", "1", "--quiet", "--out", str(root / "semantics-v1")],
                   check=True)
    return root


def test_board_shows_each_phenomenon(semantics_root: Path, tmp_path: Path) -> None:
    part = semantics_root / "semantics-v1" / "test"
    entries = tmp_path / "leaderboards" / "entries"  # laid out as in the repository
    predictions = tmp_path / "leaderboards" / "predictions"
    entries.mkdir(parents=True)
    predictions.mkdir()
    for baseline in ("oracle", "noop"):
        out = predictions / f"{baseline}.jsonl.gz"
        subprocess.run([*CLI, "baseline", baseline, "--data", str(part), "--out", str(out)],
                       check=True, capture_output=True)
        (entries / f"semantics-v1-test--{baseline}-v1.json").write_text(json.dumps({
            "model": f"{baseline}-v1", "split": "semantics-v1/test",
            "predictions": f"../predictions/{out.name}",
            "kind": "baseline", "description": baseline}))
    boards = build(entries, semantics_root, tmp_path / "out")
    rows = {r["model"]: r for r in boards["semantics-v1/test"]}
    oracle, noop = rows["oracle-v1"], rows["noop-v1"]
    assert set(oracle["phenomena"]) == set(PHENOMENA)
    for figures in oracle["phenomena"].values():
        for metric in PHENOMENON_COLUMNS:
            if metric in figures and figures[metric][3] > 0:
                assert figures[metric][0] == 1.0, metric
    # the do-nothing row keeps everything still and succeeds exactly where nothing is asked
    assert noop["phenomena"]["prohibition"]["success_strict"][0] == 1.0
    assert noop["phenomena"]["question"]["abstention"][0] == 1.0
    assert noop["phenomena"]["two_sentence"]["success_strict"][0] == 0.0
    assert noop["metrics"]["kept_still"][0] == 1.0
    assert noop["n"] == 18
    board = (tmp_path / "out" / "semantics-v1-test.md").read_text("utf-8")
    assert "## By phenomenon" in board
    assert "| prohibition | noop-v1 |" in board
    assert "ranked by strict success" in board  # IoU-M is undefined where nothing moves
