"""Robot benchmarks: one pick-and-place per motion profile, one replayed episode.

Run with ``pytest tests/bench/test_robot_bench.py -o addopts="" --benchmark-only``.
The report's figures (pick-and-places/s and episodes/s on both cores, success rate over
hundreds of steps, robot-vs-teleport differences) come from ``benchmarks/bench_robot.py``,
which runs spawned workers in parallel; these time single calls in one process.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.generators.sampler import sample_episode

pytestmark = [pytest.mark.sim, pytest.mark.slow]

ENTROPY = 20261124


@pytest.fixture(scope="module")
def world() -> Iterator[Any]:
    from nsrmp_bench.generators.world.world import World

    with World() as w:
        yield w


@pytest.mark.parametrize("profile", ["fast", "realistic"])
def test_one_pick_and_place(benchmark: Any, world: Any, profile: str) -> None:
    from nsrmp_bench.generators.replay.episode import stage_scene
    from nsrmp_bench.generators.robot.pick_and_place import execute_program

    ep = sample_episode(EpisodeConfig(objects=10, steps=1), ENTROPY, 0, "bench/0")

    def setup() -> tuple[tuple[Any, ...], dict[str, Any]]:
        stage_scene(world, ep.scene)
        return (world, ep.scene, ep.states, ep.grounded, profile), {}

    result = benchmark.pedantic(execute_program, setup=setup, rounds=5 if profile == "fast"
                                else 2, iterations=1)
    assert result.success


def test_one_replayed_episode(benchmark: Any, world: Any) -> None:
    """Stage, plan from the gold boxes, execute 3 steps, measure: one replay line."""
    from nsrmp_bench.episode import Episode
    from nsrmp_bench.generators.replay.episode import PredictedPlacement, replay_episode
    from nsrmp_bench.geometry.default_camera import OFFICIAL_CAMERA
    from nsrmp_bench.geometry.projection import states_boxes

    ep = sample_episode(EpisodeConfig(objects=8, steps=3), ENTROPY, 1, "bench/1")
    boxes = states_boxes(OFFICIAL_CAMERA, ep.scene.objects, ep.states)[-1]
    placement = PredictedPlacement(boxes=boxes)
    result = benchmark.pedantic(replay_episode, args=(world, Episode(ep), placement),
                                rounds=2, iterations=1)
    assert result.success
