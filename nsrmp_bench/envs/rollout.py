"""Running a policy in closed loop on every instance of a part, into a predictions file.

Each task builds its own environment (one PyBullet world per process) and policy from
their names, so any engine runs them; the predictions are the *achieved* final boxes
(:meth:`TabletopEnv.prediction`), which the public scorer scores like any other file.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from nsrmp_bench.engine.base import Engine
from nsrmp_bench.engine.progress import TaskReport
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["RolloutConfig", "rollout_ids", "rollout_part", "run_episode"]


@dataclass(frozen=True)
class RolloutConfig:
    """What every task needs to rebuild the environment and the policy."""

    policy: str
    data: str | None
    split: str | None
    part: str
    executor: str = "teleport"
    boxes: str | None = None
    step_margin: int = 2
    control: str = "pick_place"

    def make_env(self) -> Any:
        """The environment these settings describe."""
        from nsrmp_bench.envs.tabletop import TabletopEnv

        return TabletopEnv(self.data, split=self.split, part=self.part, boxes=self.boxes,
                           executor=self.executor, step_margin=self.step_margin,
                           control=self.control)


def run_episode(env: Any, policy: Any, instance: str | int) -> tuple[Prediction, dict[str, Any]]:
    """Run ``policy`` on ``instance`` until it says done or the episode is truncated."""
    obs, info = env.reset(options={"instance": instance})
    reset = getattr(policy, "reset", None)
    if callable(reset):
        reset(obs, info)
    failures: list[str] = []
    while True:
        obs, _, terminated, truncated, info = env.step(policy(obs))
        if info["failure"]:
            failures.append(info["failure"])
        if terminated or truncated:
            break
    summary = {"id": info["instance"], "is_success": bool(info["is_success"]),
               "moves": int(info["step"]), "truncated": bool(truncated),
               "failures": failures}
    return env.unwrapped.prediction(), summary


def rollout_ids(config: RolloutConfig, ids: Sequence[str], *, report: TaskReport
                ) -> list[tuple[Prediction, dict[str, Any]]]:
    """One task: every instance of ``ids`` in order, with a fresh environment."""
    from nsrmp_bench.envs.policies import make_policy

    env = config.make_env()
    try:
        policy = make_policy(config.policy, env)
        out = []
        for instance in ids:
            out.append(run_episode(env, policy, instance))
            report.advance()
        return out
    finally:
        env.close()


def rollout_part(config: RolloutConfig, ids: Sequence[str], engine: Engine, *,
                 tasks: int = 1, progress: Callable[[int], None] | None = None
                 ) -> list[tuple[Prediction, dict[str, Any]]]:
    """Every instance of ``ids`` split into ``tasks`` contiguous tasks; results in order."""
    from nsrmp_bench.engine.base import in_task_order

    n = max(1, min(tasks, len(ids)))
    bounds = [round(k * len(ids) / n) for k in range(n + 1)]
    chunks = [(config, list(ids[bounds[k]:bounds[k + 1]])) for k in range(n)]
    done = 0

    def on_progress(count: int) -> None:
        nonlocal done
        done += count
        if progress is not None:
            progress(done)

    results = in_task_order(engine.map_unordered(rollout_ids, chunks, on_progress=on_progress))
    return [item for chunk in results for item in chunk]

