"""Replaying many episodes, in this process, a pool of worker processes or a Dask cluster.

Chunks of episodes are tasks handed to an engine (``nsrmp_bench.engine``). Each worker
process builds one :class:`World` and reuses it for every episode it is given, so an
episode's result depends only on the episode and the prediction (the World resets its
contact state per instance). Results come back in task order whatever the worker count.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.engine import Engine, TaskReport, in_task_order, open_engine
from nsrmp_bench.episode import Episode
from nsrmp_bench.episode_views import episode_camera, episode_initial_state
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
from nsrmp_bench.scoring.submission import Prediction
from nsrmp_bench.storage.atomic import atomic_write_bytes

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


def _write_png(path: Path, left: NDArray[np.uint8], right: NDArray[np.uint8]) -> None:
    from nsrmp_bench._optional import require

    cv2 = require("cv2")
    img = np.concatenate([left, right], axis=1)
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(img[:, :, ::-1]))
    if ok:
        atomic_write_bytes(path, bytes(buf))


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
               render_dir: str | None, *, report: TaskReport) -> list[ReplayOutcome]:
    """The task of one chunk of instances, whichever engine runs it."""
    out = []
    for t in tasks:
        out.append(_run_one(t, profile, source, render_dir))
        report.advance()
    return out


def replay_tasks(
    tasks: Iterable[ReplayTask],
    *,
    profile: str = "fast",
    source: str = "auto",
    workers: int = 1,
    engine: Engine | None = None,
    render_dir: str | Path | None = None,
    chunk: int = 4,
    progress: Callable[[int], None] | None = None,
) -> Iterator[ReplayOutcome]:
    """Replay every task; outcomes in task order.

    Chunks of ``chunk`` tasks go to ``engine`` (entered by the caller), by default the local
    one: this process when ``workers`` is 1, else that many spawned processes.
    """
    get_profile(profile)  # fail early on an unknown profile
    if workers < 1:
        msg = f"workers must be >= 1, got {workers}; use 1 to replay in this process"
        raise InvalidArgument(msg)
    rdir = None if render_dir is None else str(Path(render_dir).resolve())
    if rdir is not None:
        Path(rdir).mkdir(parents=True, exist_ok=True)
    items = list(tasks)
    chunks = [(items[i : i + chunk], profile, source, rdir)
              for i in range(0, len(items), chunk)]
    done = 0
    with contextlib.ExitStack() as stack:
        if engine is None:
            engine = stack.enter_context(open_engine("local", workers=workers))
        if rdir is not None:
            engine.require_shared_dir(Path(rdir))
        for outcomes in in_task_order(engine.map_unordered(_run_chunk, chunks)):
            for outcome in outcomes:
                done += 1
                yield outcome
                if progress is not None:
                    progress(done)
