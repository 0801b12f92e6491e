"""``control="ee"``: end-effector actions through the Panda's inverse kinematics, the
scripted ``oracle-ee`` solving it, and the scorer scoring it like any rollout."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("gymnasium")
pytest.importorskip("pybullet")

from nsrmp_bench.cli.main import main
from nsrmp_bench.envs.tabletop import TabletopEnv
from nsrmp_bench.errors import InvalidAction, InvalidArgument
from nsrmp_bench.scoring.reader import read_submission
from nsrmp_bench.scoring.scorer import score

pytestmark = pytest.mark.sim


def test_oracle_ee_rollout_is_scored_by_the_scorer(smoke_v2_test: Path, tmp_path: Path) -> None:
    out = tmp_path / "ee.jsonl"
    assert main(["rollout", "oracle-ee", "--control", "ee", "--data", str(smoke_v2_test),
                 "--out", str(out), "--limit", "2", "--quiet"]) == 0
    sub = read_submission(out)
    assert sub.header.extra["rollout"]["control"] == "ee"
    assert sub.header.extra["rollout"]["executor"] == "robot"
    result = score(out, smoke_v2_test, n_boot=0, breakdown=False)
    # two of sixteen instances: the others are missing, so failures
    assert result.value("success") == pytest.approx(2 / 16)


def test_the_hand_follows_the_commanded_change(smoke_v2_test: Path) -> None:
    env = TabletopEnv(smoke_v2_test, control="ee")
    try:
        obs, info = env.reset(options={"instance": 0})
        assert obs["proprio"].shape == (12,) and obs["proprio"].dtype == np.float32
        assert info["max_steps"] == 80 * (env.episode.symbolic.num_steps + 2)
        start = obs["proprio"][:3].astype(np.float64)
        for _ in range(3):
            obs, reward, terminated, truncated, info = env.step(
                {"ee": [0.03, 0.0, -0.02, 0.0], "gripper": 1.0, "done": 0})
        moved = obs["proprio"][:3] - start
        np.testing.assert_allclose(moved, [0.09, 0.0, -0.06], atol=0.004)
        assert info["step"] == 3 and not (terminated or truncated) and reward == 0.0
        assert env.observation_space.contains(obs)
        obs, reward, terminated, truncated, info = env.step({"done": 1})
        assert terminated and not info["is_success"]  # nothing was moved
    finally:
        env.close()


@pytest.mark.parametrize(("action", "words"), [
    ({"ee": [0.0, 0.0, 0.0]}, "4 finite numbers"),
    ({"ee": [0.0, 0.0, np.nan, 0.0]}, "4 finite numbers"),
    ({"ee": [0.0] * 4, "gripper": 2.0}, "in \\[0, 1\\]"),
    ({"pick": (1.0, 1.0), "place": (2.0, 2.0)}, "unknown action key"),
    ({"gripper": 0.5}, "needs 'ee'"),
])
def test_bad_end_effector_actions_are_named(smoke_v2_test: Path, action: dict[str, object],
                                            words: str) -> None:
    env = TabletopEnv(smoke_v2_test, control="ee")
    try:
        env.reset(options={"instance": 0})
        with pytest.raises(InvalidAction, match=words):
            env.step(action)
    finally:
        env.close()


def test_control_and_policy_must_agree(smoke_v2_test: Path, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "p.jsonl"
    assert main(["rollout", "oracle-ee", "--data", str(smoke_v2_test), "--out",
                 str(out)]) != 0
    assert "add --control ee" in capsys.readouterr().err
    assert main(["rollout", "oracle", "--control", "ee", "--data", str(smoke_v2_test),
                 "--out", str(out)]) != 0
    assert "issues whole moves" in capsys.readouterr().err
    with pytest.raises(InvalidArgument, match="control='fly'"):
        TabletopEnv(smoke_v2_test, control="fly")
    assert not out.exists()
