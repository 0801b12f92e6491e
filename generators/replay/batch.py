"""Replaying many episodes, in this process or in a pool of worker processes.

Each worker builds one :class:`World` and reuses it for every episode it is given, so an
episode's result depends only on the episode and the prediction (the World resets its
contact state per instance). Results come back in task order whatever the worker count.
"""

from __future__ import annotations

import multiprocessing
import os
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument, NSRMPError
from nsrmp_bench.generators.replay.episode import (
    PredictedPlacement,
    achieved_prediction,
    replay_episode,
    stage_scene,
)
from nsrmp_bench.generators.replay.plan import ReplayPlan
from nsrmp_bench.generators.robot.profiles import get_profile
from nsrmp_bench.generators.world.world import World
from nsrmp_bench.scoring.projection import episode_camera, episode_initial_state
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["ReplayOutcome", "ReplayTask", "replay_tasks"]


@dataclass(frozen=True, eq=False)
class ReplayTask:
    """One episode and its prediction, to be replayed."""

    episode: Episode
    placement: PredictedPlacement


@dataclass(frozen=True, eq=False)
class ReplayOutcome:
    """The achieved prediction and a JSON-able summary. ``error`` says why nothing could
    be carried out (the robot then left the scene as it was)."""

    episode_id: str
    prediction: Prediction
    summary: dict[str, Any]
    error: str | None = None


_WORLD: World | None = None


def _world() -> World:
    global _WORLD
    if _WORLD is None:
        _WORLD = World()
    return _WORLD


def _safe_name(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text)


def _write_png(path: Path, left: Any, right: Any) -> None:
    from nsrmp_bench._optional import require

    cv2 = require("cv2")
    img = np.concatenate([left, right], axis=1)
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(img[:, :, ::-1]))
    if ok:
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_bytes(bytes(buf))
        os.replace(tmp, path)


def _run_one(task: ReplayTask, profile: str, source: str,
             render_dir: str | None) -> ReplayOutcome:
    world = _world()
    ep = task.episode
    error: str | None = None
    try:
        result = replay_episode(world, ep, task.placement, profile, source=source)
    except NSRMPError as exc:  # nothing to carry out: the robot leaves the scene as it is
        error = str(exc)
        result = replay_episode(world, ep, task.placement, profile, source=source,
                                plan=ReplayPlan(source, (), ()))
    pred = achieved_prediction(result, ep, task.placement)
    if render_dir is not None:  # initial | achieved, side by side
        camera = episode_camera(ep)
        final = world.render(camera)
        stage_scene(world, episode_initial_state(ep))
        initial = world.render(camera)
        _write_png(Path(render_dir) / f"{_safe_name(ep.id)}.png", initial.rgb, final.rgb)
    summary = result.summary()
    if error is not None:
        summary["error"] = error
    return ReplayOutcome(ep.id, pred, summary, error)


def _run_chunk(tasks: Sequence[ReplayTask], profile: str, source: str,
               render_dir: str | None) -> list[ReplayOutcome]:
    return [_run_one(t, profile, source, render_dir) for t in tasks]


def replay_tasks(
    tasks: Iterable[ReplayTask],
    *,
    profile: str = "fast",
    source: str = "auto",
    workers: int = 1,
    render_dir: str | Path | None = None,
    chunk: int = 4,
    progress: Callable[[int], None] | None = None,
) -> Iterator[ReplayOutcome]:
    """Replay every task; outcomes in task order. ``workers > 1`` uses spawned processes."""
    get_profile(profile)  # fail early on an unknown profile
    if workers < 1:
        msg = f"workers must be >= 1, got {workers}; use 1 to replay in this process"
        raise InvalidArgument(msg)
    rdir = None if render_dir is None else str(render_dir)
    if rdir is not None:
        Path(rdir).mkdir(parents=True, exist_ok=True)
    items = list(tasks)
    if workers == 1:
        for k, t in enumerate(items):
            yield _run_one(t, profile, source, rdir)
            if progress is not None:
                progress(k + 1)
        return
    chunks = [items[i : i + chunk] for i in range(0, len(items), chunk)]
    ctx = multiprocessing.get_context("spawn")
    done = 0
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        futures = [pool.submit(_run_chunk, c, profile, source, rdir) for c in chunks]
        for fut in futures:
            for outcome in fut.result():
                done += 1
                yield outcome
                if progress is not None:
                    progress(done)
