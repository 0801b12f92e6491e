"""``nsrmp-bench rollout``: closed-loop predictions files the public scorer scores."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("gymnasium")
pytest.importorskip("pybullet")

from nsrmp_bench.cli.main import main
from nsrmp_bench.envs.policies import check_policy
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.scoring.reader import read_submission
from nsrmp_bench.scoring.scorer import score

pytestmark = pytest.mark.sim


def test_oracle_rollout_scores_near_one(smoke_v2_test: Path, tmp_path: Path) -> None:
    out = tmp_path / "oracle.closed.jsonl"
    report = tmp_path / "report.json"
    assert main(["rollout", "oracle", "--data", str(smoke_v2_test), "--out", str(out),
                 "--report", str(report), "--quiet"]) == 0
    sub = read_submission(out)
    assert sub.header.split == "smoke-v2/test"
    assert sub.header.extra["rollout"]["policy"] == "oracle"
    result = score(out, smoke_v2_test, n_boot=0, breakdown=False)
    assert result.value("iou_m") >= 0.95
    assert result.value("success") >= 0.9
    assert result.value("program_exact") == 1.0  # the program it carried out is gold's
    lines = json.loads(report.read_text())["instances"]
    assert len(lines) == 16 and sum(x["is_success"] for x in lines) >= 15


def test_any_callable_policy_by_module_and_name(smoke_v2_test: Path, tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "my_policies.py").write_text(
        "calls = []\n"
        "def stop(observation):\n"
        "    calls.append(observation['instruction'])\n"
        "    return {'done': 1}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "stop.jsonl"
    assert main(["rollout", "my_policies:stop", "--data", str(smoke_v2_test), "--out",
                 str(out), "--limit", "3", "--quiet"]) == 0
    import my_policies  # type: ignore[import-not-found]

    assert len(my_policies.calls) == 3
    result = score(out, smoke_v2_test, n_boot=0, breakdown=False)
    # nothing moved: the floor; missing instances count as failures
    assert result.value("iou_m") < 0.3


def test_unknown_policy_is_refused(smoke_v2_test: Path, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "p.jsonl"
    assert main(["rollout", "greedy", "--data", str(smoke_v2_test), "--out", str(out)]) != 0
    assert "unknown policy 'greedy'" in capsys.readouterr().err
    assert main(["rollout", "no_such_module_xyz:f", "--data", str(smoke_v2_test), "--out",
                 str(out)]) != 0
    assert "'no_such_module_xyz' cannot be imported" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(InvalidArgument, match="unknown policy 'greedy'"):
        check_policy("greedy")


def test_nsrm_policy_rolls_out_its_predicted_program(smoke_v2_test: Path,
                                                     tmp_path: Path) -> None:
    pytest.importorskip("torch")
    out = tmp_path / "nsrm.closed.jsonl"
    assert main(["rollout", "nsrm", "--data", str(smoke_v2_test), "--out", str(out),
                 "--limit", "4", "--quiet"]) == 0
    sub = read_submission(out)
    assert sub.header.extra["rollout"]["boxes"] == "gold"
    assert len(sub.ids) == 4
    # a line carries the program when every move was a DSL step the environment carried
    # out (a predicted self-move or an empty program leaves it out)
    assert sub.has_program.sum() >= 3
