"""Generated instances for the robot tests."""

from __future__ import annotations

from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.episode import SymbolicEpisode
from nsrmp_bench.generators.sampler import sample_episode


def generated(objects: int, steps: int, index: int, relational: str = "none",
              entropy: int = 2024) -> SymbolicEpisode:
    """A generated symbolic episode (a pure function of its arguments)."""
    config = EpisodeConfig(objects=objects, steps=steps, relational=relational)
    return sample_episode(config, entropy, index, f"robot-test/{index:06d}")
