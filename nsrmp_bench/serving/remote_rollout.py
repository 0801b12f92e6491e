"""``rollout --server``: the environment here, the policy in a server's process.

Each instance is run as in process (:func:`nsrmp_bench.envs.rollout.run_episode`), the
policy's calls going over one connection: ``episode_start`` (instance, split, camera,
boxes, control, step limit), one ``observation`` / ``action`` pair per step,
``episode_end`` (success, moves, truncated). Each finished instance goes to the run's
journal (:mod:`nsrmp_bench.serving.journal`) at once. A connection that drops is reopened
up to ``retries`` times and the instance rerun from its start (the environment is
deterministic, so a deterministic policy gives the same bytes); a silent server (no reply
within the timeout), a protocol fault or a policy error stops the run with a sentence, the
journal kept for the rerun.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

from nsrmp_bench.errors import PolicyServerError
from nsrmp_bench.scoring.submission import Prediction
from nsrmp_bench.serving.client import ConnectionLost, PolicyClient
from nsrmp_bench.serving.journal import RolloutJournal
from nsrmp_bench.serving.policy_source import camera_payload

__all__ = ["RemotePolicy", "rollout_remote"]


class RemotePolicy:
    """A policy whose calls go to a server: ``reset`` starts the episode there."""

    def __init__(self, client: PolicyClient, env: Any, split: str) -> None:
        self.client = client
        self.env = env.unwrapped
        self.split = split

    def reset(self, observation: dict[str, Any], info: dict[str, Any]) -> None:
        """Send ``episode_start`` for the instance the environment just reset to."""
        self.client.start_episode({
            "instance": str(info["instance"]), "split": self.split,
            "camera": camera_payload(self.env.camera), "boxes": self.env.boxes_mode,
            "control": getattr(self.env, "control", "pick_place"),
            "max_steps": int(info["max_steps"])})

    def __call__(self, observation: dict[str, Any]) -> dict[str, Any]:
        return self.client.act(observation)


def rollout_remote(config: Any, ids: Sequence[str], client: PolicyClient,
                   journal: RolloutJournal, *, split: str, retries: int = 2,
                   progress: Callable[[int], None] | None = None
                   ) -> list[tuple[Prediction, dict[str, Any]]]:
    """Every instance of ``ids`` not yet in ``journal``, through ``client``; then all of
    them, in ``ids`` order, from the journal."""
    from nsrmp_bench.envs.rollout import run_episode
    from nsrmp_bench.serving.journal import prediction_from_record

    env = config.make_env()
    try:
        policy = RemotePolicy(client, env, split)
        done = sum(i in journal.records for i in ids)
        if progress is not None and done:
            progress(done)
        for instance in ids:
            if instance in journal.records:
                continue
            reconnect = False
            for attempt in range(retries + 1):
                try:
                    if reconnect:  # a failed reconnection counts as an attempt too
                        client.connect()
                    prediction, summary = run_episode(env, policy, instance)
                    client.end_episode({"instance": instance,
                                        "is_success": summary["is_success"],
                                        "moves": summary["moves"],
                                        "truncated": summary["truncated"]})
                    break
                except ConnectionLost:
                    if attempt == retries:
                        raise
                    time.sleep(min(2.0, 0.5 * (attempt + 1)))
                    reconnect = True
            journal.add(prediction, summary)
            done += 1
            if progress is not None:
                progress(done)
    finally:
        env.close()
    missing = [i for i in ids if i not in journal.records]
    if missing:  # pragma: no cover - the loop above fills every id or raises
        msg = f"instances {missing[:3]} have no result; rerun to resume"
        raise PolicyServerError(msg)
    return [(prediction_from_record(journal.records[i]), journal.summaries[i]) for i in ids]
