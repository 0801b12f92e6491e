"""docs/policy-server.md's worked example: its policy served from its own folder, in its
own process, driven by ``rollout --server``, scored by the public scorer."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("gymnasium")
pytest.importorskip("pybullet")
pytest.importorskip("websockets")

from nsrmp_bench.cli.main import main
from nsrmp_bench.scoring.scorer import score

pytestmark = pytest.mark.sim

PAGE = Path(__file__).resolve().parents[2] / "docs" / "policy-server.md"


def test_the_pages_policy_runs_over_the_server(smoke_v2_test: Path, tmp_path: Path,
                                                serve_process: Any) -> None:
    text = PAGE.read_text("utf-8")
    code = text.split("```python\n# my_policy.py", 1)[1].split("```", 1)[0]
    folder = tmp_path / "policies"
    folder.mkdir()
    (folder / "my_policy.py").write_text("# my_policy.py" + code)
    out = tmp_path / "largest.jsonl"
    with serve_process(["my_policy:Policy"], cwd=folder) as (url, _):
        assert main(["rollout", "--server", url, "--boxes", "gold", "--data",
                     str(smoke_v2_test), "--out", str(out), "--limit", "4", "--quiet"]) == 0
    result = score(out, smoke_v2_test, n_boot=0, breakdown=False)
    assert 0.0 <= result.value("iou_m") <= 1.0
