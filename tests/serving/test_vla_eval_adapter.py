"""vla-eval's own runner and connection drive the benchmark (``TabletopBenchmark``)
against ``nsrmp-bench serve`` in another process: the two ends interoperate, and the
achieved scenes equal the in-process oracle rollout's."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("gymnasium")
pytest.importorskip("pybullet")
pytest.importorskip("websockets")
pytest.importorskip("vla_eval")

from vla_eval.connection import Connection
from vla_eval.runners.sync_runner import SyncEpisodeRunner

from nsrmp_bench.envs.policies import make_policy
from nsrmp_bench.envs.rollout import run_episode
from nsrmp_bench.envs.tabletop import TabletopEnv
from nsrmp_bench.serving.vla_eval_benchmark import TabletopBenchmark

pytestmark = pytest.mark.sim

LIMIT = 3


async def _run(bench: TabletopBenchmark, url: str) -> list[dict[str, Any]]:
    runner = SyncEpisodeRunner()
    out = []
    async with Connection(url, timeout=60) as conn:
        for task in bench.get_tasks():
            out.append(await runner.run_episode(
                bench, task, conn, max_steps=bench.get_metadata()["max_steps"]))
    return out


def test_vla_eval_runs_the_benchmark_against_our_server(smoke_v2_test: Path, tmp_path: Path,
                                                        serve_process: Any) -> None:
    bench = TabletopBenchmark(smoke_v2_test, limit=LIMIT)
    try:
        with serve_process(["oracle", "--data", str(smoke_v2_test)], cwd=tmp_path) as (url, _):
            results = asyncio.run(_run(bench, url))
        remote = [p.to_record() for p in bench.predictions()]
    finally:
        bench.cleanup()
    assert [r["metrics"]["success"] for r in results] == [True] * LIMIT
    env = TabletopEnv(smoke_v2_test)
    try:
        policy = make_policy("oracle", env)
        local = [run_episode(env, policy, i)[0].to_record() for i in range(LIMIT)]
    finally:
        env.close()
    assert remote == local
