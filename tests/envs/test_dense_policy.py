"""The dense baseline as a closed-loop policy (``rollout dense``) on a real generated part
(smoke-v2/test) with the shipped ``dense-v2`` checkpoint: its first move is the open-loop
prediction's, it stops on its own, and it runs on gold or detected boxes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("gymnasium")
pytest.importorskip("pybullet")
pytest.importorskip("torch")

from nsrmp_bench.cli.main import main
from nsrmp_bench.dataset import EpisodeDataset
from nsrmp_bench.envs.policies import make_policy
from nsrmp_bench.envs.tabletop import TabletopEnv
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.registry import load_predictor
from nsrmp_bench.scoring.reader import read_submission

pytestmark = pytest.mark.sim


def test_first_move_is_the_open_loop_prediction(smoke_v2_test: Path) -> None:
    ds = EpisodeDataset(smoke_v2_test)
    items = [ds[i] for i in range(5)]
    predictor = load_predictor("dense")
    assert predictor.model_id == "dense-v2"
    open_loop = {p.id: p for p in predictor.predict(items)}
    env = TabletopEnv(smoke_v2_test, boxes="gold")
    try:
        policy = make_policy("dense", env)
        for item in items:
            obs, info = env.reset(options={"instance": item["id"]})
            policy.reset(obs, info)  # type: ignore[attr-defined]
            action = policy(obs)
            want = open_loop[item["id"]]
            assert action["done"] == 0
            np.testing.assert_allclose(action["pick"], want.pick, atol=1e-4)
            np.testing.assert_allclose(action["place"], want.place, atol=1e-4)
            obs, _, terminated, truncated, info = env.step(action)
            assert info["failure"] is None and info["moved"] is not None
            # it goes on until it says done (its move would change nothing) or truncation
            while not (terminated or truncated):
                obs, _, terminated, truncated, info = env.step(policy(obs))
            assert 1 <= info["step"] <= info["max_steps"]
    finally:
        env.close()


def test_rollout_dense_on_gold_and_on_detected_boxes(smoke_v2_test: Path,
                                                     tmp_path: Path) -> None:
    for boxes in (None, "classical"):
        out = tmp_path / f"dense-{boxes}.jsonl"
        report = tmp_path / f"dense-{boxes}.json"
        args = ["rollout", "dense", "--data", str(smoke_v2_test), "--out", str(out),
                "--report", str(report), "--limit", "4", "--quiet"]
        if boxes is not None:
            args += ["--boxes", boxes]
        assert main(args) == 0
        sub = read_submission(out)
        assert sub.header.extra["rollout"]["boxes"] == (boxes or "gold")
        assert len(sub.ids) == 4
        lines = json.loads(report.read_text())["instances"]
        assert all(x["moves"] >= 1 for x in lines)
        assert not np.isnan(sub.pick).any() and not np.isnan(sub.place).any()


def test_bad_box_settings_are_refused(smoke_v2_test: Path, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    env = TabletopEnv(smoke_v2_test)
    try:
        with pytest.raises(InvalidArgument, match=r"policy 'dense' reads boxes.*boxes='gold'"):
            make_policy("dense", env)
    finally:
        env.close()
    out = tmp_path / "p.jsonl"
    assert main(["rollout", "nsrm", "--boxes", "classical", "--data", str(smoke_v2_test),
                 "--out", str(out)]) != 0
    assert "--boxes classical gives detections in score order" in capsys.readouterr().err
    assert not out.exists()
