"""Figures for the symbolic generator: samples/s, template counts, needed-relation fraction.

Run: .venv/bin/python scripts/bench_sampler.py [--n 400]
"""

from __future__ import annotations

import argparse
import time

from nsrmp_bench.config import EpisodeConfig
from nsrmp_bench.generators.sampler import sample_episode
from nsrmp_bench.generators.templates import load_language


def rate(config: EpisodeConfig, n: int) -> float:
    """Symbolic samples per second on one core (attempts included)."""
    t = time.perf_counter()
    for i in range(n):
        sample_episode(config, 12345, i, "bench")
    return n / (time.perf_counter() - t)


def needed_fraction(n: int) -> tuple[float, float, int]:
    """Among relational references (paper-v2-like episodes, relational='any'), the share
    whose object attributes alone were ambiguous; and the share of episodes with one."""
    refs = needed = episodes_with = 0
    for objects in (3, 4, 5):
        for steps in (1, 2):
            config = EpisodeConfig(objects=objects, steps=steps, relational="any")
            for i in range(n // 6):
                ep = sample_episode(config, 777, i, "bench")
                rel = [r for r in ep.references if r.relational]
                refs += len(rel)
                needed += sum(r.needed for r in rel)
                episodes_with += any(r.needed for r in rel)
    return needed / refs, episodes_with / (6 * (n // 6)), refs


def main() -> None:
    """Print the figures."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--n", type=int, default=400)
    args = parser.parse_args()
    for objects in (5, 15):
        for steps in (1, 5):
            for relational in ("none", "any"):
                cfg = EpisodeConfig(objects=objects, steps=steps, relational=relational)
                print(f"{objects:2d} objects, {steps} steps, relational={relational:4s}: "
                      f"{rate(cfg, args.n):7.1f} samples/s (one core)")
    print("language:", load_language().counts())
    frac, ep_frac, refs = needed_fraction(args.n * 3)
    print(f"relational references where the relation is needed (3-5 objects, 1-2 steps): "
          f"{frac:.3f} of {refs}; episodes with a needed relation: {ep_frac:.3f}")


if __name__ == "__main__":
    main()
