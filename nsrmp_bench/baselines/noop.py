"""``noop-v1``: nothing moves: every final box is the object's initial box.

The floor the paper never reported: it scores about (N-k)/N on IoU but near zero on IoU-M.
Its program is empty, so it scores zero on program accuracy.
"""

from __future__ import annotations

import numpy as np

from nsrmp_bench.episode import Episode
from nsrmp_bench.episode_views import episode_boxes, episode_positions
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["noop_prediction"]


def noop_prediction(episode: Episode, rng: np.random.Generator) -> Prediction:
    """The do-nothing prediction for one episode (``rng`` is unused)."""
    initial = episode_boxes(episode)[0]
    steps = episode.symbolic.num_steps
    return Prediction(
        id=episode.id,
        boxes=initial,
        program=(),
        step_boxes=np.repeat(initial[None], steps, axis=0),
        positions=episode_positions(episode)[0],
    )
