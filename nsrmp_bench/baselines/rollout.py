"""Turning a sequence of grounded steps on an episode's initial scene into a prediction.

The steps are executed by the symbolic executor from the episode's initial state (for a
rendered episode, the rendered initial poses), and every state is projected through the
episode's camera. The pick location is the centre of the first subject's initial box, the
place location the centre of its box after the first step.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from nsrmp_bench.dsl.actions import target_pose
from nsrmp_bench.dsl.executor import execute_grounded
from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.episode import Episode
from nsrmp_bench.episode_views import episode_camera, episode_initial_state
from nsrmp_bench.errors import InfeasibleStep
from nsrmp_bench.geometry.boxes import box_centres
from nsrmp_bench.geometry.projection import states_boxes
from nsrmp_bench.scene import Scene, State
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["execute_leniently", "rollout_prediction"]


def execute_leniently(scene: Scene, steps: Sequence[GroundedStep]) -> tuple[list[State], int]:
    """Every state after executing ``steps``, and how many steps failed their checks.

    A step the executor refuses (possible when rendered initial poses differ from the
    symbolic ones) is applied without its checks: the object goes to the step's target.
    """
    try:
        return list(execute_grounded(scene, steps).states), 0
    except InfeasibleStep:
        pass
    states: list[State] = [scene.initial]
    forced = 0
    for step in steps:
        try:
            after = execute_grounded(scene.at(states[-1]), [step]).states[-1]
        except InfeasibleStep:
            forced += 1
            new = target_pose(scene.objects, states[-1], step.action, step.subject, step.reference)
            after = tuple(new if i == step.subject else p for i, p in enumerate(states[-1]))
        states.append(after)
    return states, forced


def rollout_prediction(episode: Episode, steps: Sequence[GroundedStep]) -> Prediction:
    """The prediction of executing ``steps`` on ``episode``'s initial scene."""
    scene = episode_initial_state(episode)
    states, _ = execute_leniently(scene, steps)
    boxes = states_boxes(episode_camera(episode), scene.objects, states)
    positions = np.array([p.position for p in states[-1]], dtype=np.float64)
    pick = place = None
    if steps:
        s = steps[0].subject
        cx, cy = box_centres(boxes[0, s])
        pick = (float(cx), float(cy))
        px, py = box_centres(boxes[1, s])
        place = (float(px), float(py))
    n_gold = episode.symbolic.num_steps
    step_boxes = boxes[1:] if len(steps) == n_gold else None
    return Prediction(
        id=episode.id,
        boxes=boxes[-1],
        program=tuple(steps),
        step_boxes=step_boxes,
        pick=pick,
        place=place,
        positions=positions,
    )
