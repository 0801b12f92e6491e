"""``random-v1``: as many steps as the gold program, each a uniformly random legal step.

At each step it draws one of all legal (action, subject, reference) steps of the current
symbolic state (``feasible_steps``) from the given Generator, so it moves a random object
to a random legal target; it stops early if no step is legal. The number of steps is
taken from the episode (the instruction states it).
"""

from __future__ import annotations

import numpy as np

from nsrmp_bench.baselines.rollout import rollout_prediction
from nsrmp_bench.dsl.actions import feasible_steps
from nsrmp_bench.dsl.executor import execute_grounded
from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.episode import Episode
from nsrmp_bench.episode_views import episode_initial_state
from nsrmp_bench.errors import InfeasibleStep
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["random_prediction"]


def random_prediction(episode: Episode, rng: np.random.Generator) -> Prediction:
    """A random legal rollout for one episode, drawn from ``rng``."""
    scene = episode_initial_state(episode)
    state = scene.initial
    steps: list[GroundedStep] = []
    for _ in range(episode.symbolic.num_steps):
        options = feasible_steps(scene.objects, state, scene.workspace)
        if not options:
            break
        step = options[int(rng.integers(len(options)))]
        try:
            state = execute_grounded(scene.at(state), [step]).states[-1]
        except InfeasibleStep:  # pragma: no cover - feasible_steps checked it
            break
        steps.append(step)
    return rollout_prediction(episode, steps)
