"""World benchmarks: one render, one realised episode (1 and 5 steps), 1024x768 samples.

Run with ``pytest tests/bench/test_render_bench.py -o addopts="" --benchmark-only``.
The figures for the report (episodes/s on both cores against the render-only bound,
samples/s at 1024x768, rejection rates) come from ``benchmarks/bench_render.py``, which runs
spawned workers in parallel; these benchmarks time single calls in one process.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.episode import SeedInfo, SymbolicEpisode
from nsrmp_bench.errors import GenerationError

pytestmark = [pytest.mark.sim, pytest.mark.slow]

ENTROPY = 20261123


def _episodes(objects: int, steps: int, n: int) -> list[SymbolicEpisode]:
    from nsrmp_bench.generators.sampler import sample_symbolic

    out: list[SymbolicEpisode] = []
    index = 0
    while len(out) < n:
        for attempt in range(64):
            try:
                out.append(sample_symbolic(EpisodeConfig(objects=objects, steps=steps),
                                           SeedInfo(ENTROPY, index, attempt), f"b{index}"))
                break
            except GenerationError:
                continue
        index += 1
    return out


@pytest.fixture(scope="module", params=[(320, 240), (1024, 768)], ids=["320x240", "1024x768"])
def world(request: pytest.FixtureRequest) -> Iterator[Any]:
    from nsrmp_bench.generators.world.world import World
    from nsrmp_bench.geometry.default_camera import official_camera

    with World(official_camera(*request.param)) as w:
        yield w


def _cycle(episodes: list[SymbolicEpisode], world: Any) -> Any:
    from nsrmp_bench.generators.world.realise import realise

    state = {"i": 0}

    def one() -> Any:
        ep = episodes[state["i"] % len(episodes)]
        state["i"] += 1
        return realise(ep.scene, ep.states, ep.grounded, world)

    return one


@pytest.mark.parametrize("composite", [False, True], ids=["full", "composite"])
def test_render_one_image(benchmark: Any, world: Any, composite: bool) -> None:
    ep = _episodes(5, 1, 1)[0]
    from nsrmp_bench.generators.world.realise import realise

    realise(ep.scene, ep.states, ep.grounded, world)  # prepares the cached background
    benchmark(world.render, composite=composite)


@pytest.mark.parametrize("steps", [1, 5])
def test_realise_an_episode(benchmark: Any, world: Any, steps: int) -> None:
    if world.camera.width > 320 and steps > 1:
        pytest.skip("at 1024x768 only 1-step samples (2 renders) are compared")
    benchmark(_cycle(_episodes(4, steps, 8), world))
