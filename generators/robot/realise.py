"""Realising an episode with the robot: the teleport pipeline, with the Panda moving objects.

:func:`realise_with_robot` runs :func:`~nsrmp_bench.generators.world.realise.realise`
(placement of the initial scene, settling, every acceptance check, rendering and
measuring every state) on a view of the World in which each *step's* placement is a
pick-and-place by the Panda (:func:`~nsrmp_bench.generators.robot.pick_and_place.execute_step`)
instead of a teleport. The initial scene is placed as usual. The rendering it returns is
the teleport pipeline's with ``executor="robot"``, the recorded :class:`Trajectory` and,
in ``physics["robot"]``, every step's result (success, error to the symbolic target,
disturbance, simulated time) and the motion profile.

``realise(..., executor="robot")`` can delegate here; until it does, call this directly.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.episode import Rendering
from nsrmp_bench.generators.robot.pick_and_place import StepResult, execute_step, robot_joint_names
from nsrmp_bench.generators.robot.profiles import (
    ROBOT_EXECUTOR_ID,
    MotionProfile,
    get_profile,
)
from nsrmp_bench.generators.robot.recorder import (
    concatenate_trajectories,
    empty_trajectory,
)
from nsrmp_bench.generators.world.realise import realise
from nsrmp_bench.generators.world.world import World
from nsrmp_bench.scene import Pose, Scene, State

__all__ = ["ROBOT_EXECUTOR", "realise_with_robot"]

ROBOT_EXECUTOR = "robot"
"""The ``Rendering.executor`` value of robot-executed episodes."""


class _RobotPlacingWorld:
    """The World as ``realise`` sees it, except that after the initial scene has settled,
    ``place`` of a step's object is carried out by the Panda."""

    def __init__(self, world: World, grounded: Sequence[GroundedStep], states: Sequence[State],
                 profile: MotionProfile) -> None:
        self._world = world
        self._grounded = list(grounded)
        self._states = list(states)
        self._profile = profile
        self._initial_done = False
        self.results: list[StepResult] = []
        self._t = 0.0

    def __getattr__(self, name: str) -> Any:
        return getattr(self._world, name)

    def begin(self, objects: Any, *, scenery_visuals: bool = True) -> Any:
        self._initial_done = False
        self.results = []
        self._t = 0.0
        return self._world.begin(objects, scenery_visuals=scenery_visuals)

    def settle(self, *args: Any, **kwargs: Any) -> Any:
        out = self._world.settle(*args, **kwargs)
        self._initial_done = True
        return out

    def place(self, index: int, pose: Pose, lift: float = 0.0) -> None:
        if not self._initial_done:
            self._world.place(index, pose, lift=lift)
            return
        k = len(self.results)
        if k >= len(self._grounded) or self._grounded[k].subject != index:
            msg = (
                f"robot realisation expected step {k + 1} to move object "
                f"{self._grounded[k].subject if k < len(self._grounded) else None}, but "
                f"object {index} was placed; realise() and the robot disagree on the steps"
            )
            raise RuntimeError(msg)
        result = execute_step(self._world, index, pose, self._profile, step_index=k,
                              t0=self._t, symbolic_target=self._states[k + 1][index])
        self._t += result.sim_time
        self.results.append(result)


def realise_with_robot(
    scene: Scene,
    states: Sequence[State],
    grounded: Sequence[GroundedStep],
    world: World,
    *,
    profile: str | MotionProfile = "fast",
    **kwargs: Any,
) -> Rendering:
    """Realise ``scene`` through ``states`` like ``realise`` (same checks, rejections and
    targets; ``kwargs`` are realise's), the Panda carrying out every step."""
    prof = get_profile(profile)
    kwargs.pop("executor", None)
    view = _RobotPlacingWorld(world, grounded, states, prof)
    rendering = realise(scene, states, grounded, view, **kwargs)  # type: ignore[arg-type]
    results = view.results
    trajectory = (concatenate_trajectories([r.trajectory for r in results]) if results
                  else empty_trajectory(robot_joint_names(world)))
    physics = dict(rendering.physics)
    physics["robot"] = {
        "executor_id": ROBOT_EXECUTOR_ID,
        "profile": prof.to_dict(),
        "success": all(r.success for r in results),
        "steps": [r.to_dict() for r in results],
        "sim_time": sum(r.sim_time for r in results),
    }
    return dataclasses.replace(rendering, executor=ROBOT_EXECUTOR, trajectory=trajectory,
                               physics=physics)
