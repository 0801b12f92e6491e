"""Non-learned baselines that write ordinary prediction files: oracle, noop, random.

``run_baseline("oracle", episodes, "pred.jsonl", split="smoke-v2")`` writes a file the
public scorer reads like any submission (``nsrmp-bench baseline NAME --data DATA --out PRED``).
"""

from __future__ import annotations

from nsrmp_bench.baselines.registry import BASELINES, Baseline, get_baseline, predict, run_baseline

__all__ = ["BASELINES", "Baseline", "get_baseline", "predict", "run_baseline"]
