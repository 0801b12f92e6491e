"""The score, compare, check-submission and baseline commands, end to end, and scoring
from a storage data directory."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from nsrmp_bench.cli.main import main
from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.episode import Episode, ObjectTargets, Rendering, SymbolicEpisode
from nsrmp_bench.generators.sampler import sample_episode
from nsrmp_bench.geometry.default_camera import OFFICIAL_CAMERA
from nsrmp_bench.geometry.projection import states_boxes
from nsrmp_bench.scoring import score

SPLIT = "cli-v1"


def episodes(n: int = 6) -> list[SymbolicEpisode]:
    configs = [EpisodeConfig(objects=4, steps=1), EpisodeConfig(objects=6, steps=2,
                                                                relational="any")]
    return [sample_episode(configs[i % 2], 99, i, f"{SPLIT}-test-{i:06d}", max_attempts=200)
            for i in range(n)]


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("cli") / "episodes.jsonl"
    path.write_text("".join(json.dumps(e.to_dict()) + "\n" for e in episodes()), "utf-8")
    return path


def cli(*args: str | Path) -> int:
    return main([str(a) for a in args])


def test_baseline_score_compare_check(tmp_path: Path, data: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("oracle", "noop", "random"):
        out = tmp_path / f"{name}.jsonl"
        assert cli("baseline", name, "--data", data, "--out", out, "--split", SPLIT,
                   "--seed", "3") == 0
    capsys.readouterr()
    assert cli("score", tmp_path / "noop.jsonl", "--data", data, "--split", SPLIT,
               "--json", tmp_path / "noop.json", "--per-instance", tmp_path / "noop.csv",
               "--n-boot", "200") == 0
    printed = capsys.readouterr().out
    assert "IoU-M" in printed and "Breakdown" in printed and "95% CI" in printed
    report = json.loads((tmp_path / "noop.json").read_text())
    assert report["scorer"] == "scorer-v2" and report["split"] == SPLIT
    assert report["summary"]["iou_m"]["n"] == 6
    assert report["summary"]["iou_m"]["ci_low"] <= report["summary"]["iou_m"]["value"]
    assert report["settings"]["n_boot"] == 200
    assert len((tmp_path / "noop.csv").read_text().splitlines()) == 7

    assert cli("compare", tmp_path / "oracle.jsonl", tmp_path / "noop.jsonl", "--data", data,
               "--split", SPLIT, "--json", tmp_path / "diff.json", "--n-perm", "500",
               "--quiet") == 0
    diff = {d["metric"]: d for d in json.loads((tmp_path / "diff.json").read_text())
            ["differences"]}
    assert diff["iou_m"]["diff"] > 0.5 and diff["iou_m"]["ci_low"] > 0
    assert diff["iou_m"]["p_value"] < 0.05

    assert cli("check-submission", tmp_path / "random.jsonl", "--split", SPLIT,
               "--data", data) == 0
    assert "6 of 6 instances predicted" in capsys.readouterr().out


def test_errors_are_one_message_and_status_2(tmp_path: Path, data: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"header": {"format": "nsrmp-bench-predictions", "format_version": '
                   '"1.0.0", "split": "cli-v1", "scorer": "scorer-v1"}}\n{"id": 3}\n')
    assert cli("score", bad, "--data", data, "--split", SPLIT) == 2
    err = capsys.readouterr().err
    assert "line 2" in err and "Traceback" not in err
    assert cli("check-submission", bad, "--split", "other-v1") == 2
    assert "checking it for split 'other-v1'" in capsys.readouterr().err
    assert cli("baseline", "orakel", "--data", data, "--out", tmp_path / "x.jsonl") == 2
    assert "did you mean" in capsys.readouterr().err
    assert cli("baseline", "noop", "--data", data, "--out", tmp_path / "x.jsonl") == 2
    assert "--split" in capsys.readouterr().err
    assert cli("score", bad, "--data", tmp_path / "nothing") == 2
    assert "does not exist" in capsys.readouterr().err


def _rendered(ep: SymbolicEpisode) -> Episode:
    boxes = states_boxes(OFFICIAL_CAMERA, ep.scene.objects, ep.states).astype(np.float32)
    poses = np.array([[[*p.position, *p.orientation] for p in s] for s in ep.states])
    k, n = poses.shape[:2]
    targets = ObjectTargets(poses, boxes, boxes.copy(), np.ones((k, n), np.float32),
                            np.ones((k, n), np.float32))
    return Episode(ep, Rendering(OFFICIAL_CAMERA, None, targets))


def test_scoring_a_storage_data_directory(tmp_path: Path) -> None:
    from nsrmp_bench.storage import write_shard

    eps = [_rendered(e) for e in episodes(4)]
    write_shard(tmp_path / "data", 0, eps, split=SPLIT)
    shard = next((tmp_path / "data").glob("*.h5"))
    pred = tmp_path / "oracle.jsonl"
    assert cli("baseline", "oracle", "--data", shard, "--out", pred) == 0  # split from data
    result = score(pred, shard, n_boot=0)
    assert result.split == SPLIT and result.counts["predicted"] == 4
    assert result.value("iou_m") == pytest.approx(1.0)


@pytest.fixture(scope="module")
def split_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A split root as `generate --out ROOT` leaves it: ROOT/test/ with shards and manifest."""
    from nsrmp_bench.storage import write_manifest, write_shard

    root = tmp_path_factory.mktemp("root") / "cli"
    write_shard(root / "test", 0, [_rendered(e) for e in episodes(4)], split=f"{SPLIT}/test")
    write_manifest(root / "test", split=f"{SPLIT}/test")
    return root


def test_a_split_root_as_data(tmp_path: Path, split_root: Path,
                              capsys: pytest.CaptureFixture[str]) -> None:
    pred = tmp_path / "oracle.jsonl"
    # No header to name the part: told what the root holds and what to pass.
    assert cli("baseline", "oracle", "--data", split_root, "--out", pred) == 2
    err = capsys.readouterr().err
    assert f"{split_root} is a split root holding the parts: test; pass {split_root / 'test'}" in err
    assert "Traceback" not in err and not pred.exists()
    assert cli("info", split_root) == 2
    assert "is a split root holding the parts: test" in capsys.readouterr().err

    assert cli("baseline", "oracle", "--data", split_root / "test", "--out", pred) == 0
    # The predictions' header names the part (cli-v1/test): the root is read there.
    assert cli("score", pred, "--data", split_root, "--n-boot", "0", "--json",
               tmp_path / "s.json") == 0
    assert json.loads((tmp_path / "s.json").read_text())["split"] == f"{SPLIT}/test"
    assert cli("compare", pred, pred, "--data", split_root, "--n-boot", "0",
               "--n-perm", "10") == 0
    assert cli("check-submission", pred, "--split", SPLIT, "--data", split_root) == 0
    assert score(pred, split_root, n_boot=0).value("iou_m") == pytest.approx(1.0)


def test_a_split_root_without_the_predicted_part(tmp_path: Path, split_root: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    pred = tmp_path / "val.jsonl"
    pred.write_text(json.dumps({"header": {"format": "nsrmp-bench-predictions",
                                           "format_version": "1.0.0", "split": f"{SPLIT}/val",
                                           "scorer": "scorer-v1"}}) + "\n", "utf-8")
    assert cli("score", pred, "--data", split_root) == 2
    err = capsys.readouterr().err
    assert "holding the parts: test, not the part 'val' the predictions are for" in err


def test_open_a_split_root_at_a_part(split_root: Path) -> None:
    from nsrmp_bench.errors import InvalidArgument
    from nsrmp_bench.storage import open as open_storage

    assert len(open_storage(split_root, part="test")) == 4
    with pytest.raises(InvalidArgument, match="is a split root holding the parts: test"):
        open_storage(split_root)


def test_score_prints_a_short_breakdown_unless_asked(tmp_path: Path, split_root: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    pred = tmp_path / "noop.jsonl"
    assert cli("baseline", "noop", "--data", split_root / "test", "--out", pred) == 0
    capsys.readouterr()
    assert cli("score", pred, "--data", split_root / "test", "--n-boot", "0") == 0
    short = capsys.readouterr().out
    assert "IoU-M after each step" in short and "phrasing" in short
    assert "template" not in short.split("Breakdown")[1].split("breakdown by")[0]
    assert "--breakdown all" in short
    assert cli("score", pred, "--data", split_root / "test", "--breakdown", "all",
               "--json", tmp_path / "s.json") == 0
    full = capsys.readouterr().out
    assert "template" in full and len(full.splitlines()) > len(short.splitlines())
    groups = {r["category"] for r in json.loads((tmp_path / "s.json").read_text())["per_category"]}
    assert {"steps", "objects", "relational", "phrasing", "template"} <= groups
    assert cli("score", pred, "--data", split_root / "test", "--breakdown", "none") == 0
    assert "Breakdown" not in capsys.readouterr().out
