"""``oracle-v1``: the gold grounded program, executed symbolically: the upper bound.

The gold steps run through the symbolic executor from the initial scene (rendered initial
poses for a rendered episode) and the resulting states are projected with the episode's
camera. On symbolic-only data it reproduces the gold boxes exactly; on rendered data it
differs from gold only by what physics did to the objects. Where the gold says the
instruction must not be carried out (``abstain``: the semantics split), the oracle
abstains with the gold's reason and moves nothing.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from nsrmp_bench.baselines.rollout import rollout_prediction
from nsrmp_bench.episode import Episode
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["oracle_prediction"]


def oracle_prediction(episode: Episode, rng: np.random.Generator) -> Prediction:
    """The oracle's prediction for one episode (``rng`` is unused)."""
    prediction = rollout_prediction(episode, episode.symbolic.grounded)
    if episode.symbolic.abstain:
        return replace(prediction, abstain=episode.symbolic.abstain, step_boxes=None,
                       pick=None, place=None)
    return prediction
