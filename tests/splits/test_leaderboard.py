"""The committed leaderboards are re-computable from their entries and the data."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.leaderboard import build, load_entries

pytestmark = pytest.mark.sim

BOARDS = Path(__file__).resolve().parents[2] / "leaderboards"


def test_smoke_board_rebuilds_to_the_committed_bytes(smoke_dir: Path, tmp_path: Path) -> None:
    entries = tmp_path / "entries"
    entries.mkdir()
    for entry in load_entries(BOARDS / "entries"):
        if entry.split == "smoke-v1/test":
            data = json.loads((BOARDS / "entries" / f"{entry.name}.json").read_text())
            data["predictions"] = str(entry.predictions)  # absolute: the copy moved
            (entries / f"{entry.name}.json").write_text(json.dumps(data))
    root = tmp_path / "data"
    root.mkdir()
    (root / "smoke-v1").symlink_to(smoke_dir, target_is_directory=True)
    boards = build(entries, root, tmp_path / "out")
    assert [r["model"] for r in boards["smoke-v1/test"]] == ["oracle-v1", "random-v1", "noop-v1"]
    for suffix in (".json", ".md"):
        rebuilt = (tmp_path / "out" / f"smoke-v1-test{suffix}").read_text()
        assert rebuilt == (BOARDS / f"smoke-v1-test{suffix}").read_text()


def test_bad_entries_name_the_fix(tmp_path: Path) -> None:
    (tmp_path / "x.json").write_text(json.dumps({"model": "m"}))
    with pytest.raises(InvalidArgument, match=r"needs 'model', 'split'.*'predictions'"):
        load_entries(tmp_path)
    (tmp_path / "x.json").write_text(json.dumps({"model": "m", "split": "paper-v1",
                                                  "predictions": "p.jsonl"}))
    with pytest.raises(InvalidArgument, match=r"must name a part, e.g. 'paper-v1/test'"):
        load_entries(tmp_path)
