"""pytest-benchmark: symbolic samples per call for 5 and 15 objects.

Run: .venv/bin/pytest tests/bench/test_sampler_bench.py -o addopts="" --benchmark-only
"""

from __future__ import annotations

import itertools

import pytest

from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.generators.sampler import sample_episode


@pytest.mark.parametrize("objects", [5, 15])
def test_symbolic_sample(benchmark, objects: int) -> None:  # type: ignore[no-untyped-def]
    config = EpisodeConfig(objects=objects, steps=2, relational="any")
    counter = itertools.count()
    ep = benchmark(lambda: sample_episode(config, 99, next(counter), "bench"))
    assert ep.num_objects == objects
