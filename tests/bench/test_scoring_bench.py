"""Scoring throughput on 100,000 synthetic instances: the vectorised scorer against a
plain per-instance Python loop, in the same run.

    .venv/bin/pytest tests/bench/test_scoring_bench.py --benchmark-only
    .venv/bin/python tests/bench/test_scoring_bench.py [N]      # prints the figures

The synthetic split has 3-15 objects (about 9 on average) and 1-3 steps per instance; the
predictions are partly right, 5% missing, with programs, step boxes, positions and
pick/place locations on some lines (``tests/scoring/scoring_factory.py``). Timed stages:

* ``metrics``: every per-instance value (IoU, IoU-M, success, programs, identification,
  placement, per-step IoU-M) from the gold and aligned prediction tables;
* ``headline``: metrics + means, the 95% bootstrap intervals (1000 resamples) of every
  headline figure and per-step IoU-M, and the breakdown's means and counts;
* ``full``: as headline, plus bootstrap intervals for every breakdown group;
* ``end_to_end``: reading and checking the JSON Lines file, matching it to the split,
  and ``headline``;
* ``end_to_end_parquet``: the same with the same predictions as a Parquet file (needs
  pyarrow);
* ``python_loop``: IoU, IoU-M, 2D success and two program accuracies only, one instance
  at a time in plain Python (the comparison);
* ``end_to_end_v1``: ``end_to_end`` under ``scorer-v1`` (without kept still, strict
  success and abstention); the script times it alternately with ``scorer-v2`` and prints
  the ratio of their best times (the goal: v2 within 10% of v1).
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scoring"))

from scoring_factory import (
    loop_scores,
    synthetic_tables,
    write_table_jsonl,
    write_table_parquet,
)

from nsrmp_bench.scoring.metrics import instance_scores
from nsrmp_bench.scoring.scorer import score, summarise

N = 100_000


@pytest.fixture(scope="module")
def tables() -> Any:
    return synthetic_tables(np.random.default_rng(0), N)


@pytest.fixture(scope="module")
def jsonl(tables: Any, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("bench") / "pred.jsonl"
    write_table_jsonl(*tables, path)
    return path


@pytest.fixture(scope="module")
def parquet(tables: Any, tmp_path_factory: pytest.TempPathFactory) -> Path:
    pytest.importorskip("pyarrow")
    path = tmp_path_factory.mktemp("bench") / "pred.parquet"
    write_table_parquet(*tables, path)
    return path


def _metrics(gold: Any, pred: Any) -> Any:
    return instance_scores(gold, pred)


def _headline(gold: Any, pred: Any, intervals: bool = False) -> Any:
    frame, _ = instance_scores(gold, pred)
    return summarise(gold, frame, n_boot=1000, breakdown=True, breakdown_intervals=intervals)


def test_metrics(benchmark: Any, tables: Any) -> None:
    benchmark.pedantic(_metrics, args=tables, rounds=5, iterations=1)


def test_headline(benchmark: Any, tables: Any) -> None:
    benchmark.pedantic(_headline, args=tables, rounds=3, iterations=1)


def test_full(benchmark: Any, tables: Any) -> None:
    benchmark.pedantic(_headline, args=(*tables, True), rounds=1, iterations=1)


def test_end_to_end(benchmark: Any, tables: Any, jsonl: Path) -> None:
    gold, _ = tables
    result = benchmark.pedantic(
        score, args=(jsonl, gold), kwargs={"breakdown_intervals": False}, rounds=3,
        iterations=1,
    )
    assert result.counts["instances"] == N


def test_end_to_end_v1(benchmark: Any, tables: Any, jsonl: Path) -> None:
    gold, _ = tables
    result = benchmark.pedantic(
        score, args=(jsonl, gold),
        kwargs={"breakdown_intervals": False, "scorer": "scorer-v1"}, rounds=3, iterations=1,
    )
    assert "success_strict" not in result.summary.index


def test_end_to_end_parquet(benchmark: Any, tables: Any, parquet: Path) -> None:
    gold, _ = tables
    result = benchmark.pedantic(
        score, args=(parquet, gold), kwargs={"breakdown_intervals": False}, rounds=3,
        iterations=1,
    )
    assert result.counts["instances"] == N


def test_python_loop(benchmark: Any, tables: Any) -> None:
    benchmark.pedantic(loop_scores, args=tables, rounds=1, iterations=1)


def _best(f: Callable[[], Any], repeats: int) -> tuple[float, float]:
    """Best wall and CPU seconds of ``repeats`` runs (the machine is shared)."""
    wall, cpu = [], []
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        f()
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return min(wall), min(cpu)


def main(n: int = N) -> None:
    """Print each stage's best-of-N wall and CPU time and its throughput."""
    gold, pred = synthetic_tables(np.random.default_rng(0), n)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "pred.jsonl"
        write_table_jsonl(gold, pred, path)
        stages: list[tuple[str, Callable[[], Any], int]] = [
            ("metrics", lambda: _metrics(gold, pred), 5),
            ("headline", lambda: _headline(gold, pred), 3),
            ("full", lambda: _headline(gold, pred, True), 2),
            ("end_to_end", lambda: score(path, gold, breakdown_intervals=False), 2),
            ("python_loop", lambda: loop_scores(gold, pred), 2),
        ]
        print(f"{n} instances, {len(gold.final_boxes)} objects, {len(gold.subjects)} steps; "
              f"file {path.stat().st_size / 1e6:.1f} MB")
        for name, f, repeats in stages:
            wall, cpu = _best(f, repeats)
            print(f"{name:12s} wall {wall:7.3f} s  cpu {cpu:7.3f} s  "
                  f"{n / wall:12,.0f} instances/s")
        best: dict[str, list[float]] = {"scorer-v1": [], "scorer-v2": []}
        for _ in range(4):  # alternated, so both see the same load
            for scorer, times in best.items():
                times.append(_best(lambda s=scorer: score(
                    path, gold, breakdown_intervals=False, scorer=s), 1)[1])
        v1, v2 = min(best["scorer-v1"]), min(best["scorer-v2"])
        print(f"end_to_end cpu, best of 4 alternated: scorer-v1 {v1:.3f} s, scorer-v2 "
              f"{v2:.3f} s, ratio {v2 / v1:.3f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else N)
