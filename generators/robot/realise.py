"""Realising an episode with the robot: the Panda is the placer of every step.

:class:`RobotPlacer` is the :class:`~nsrmp_bench.generators.world.realise.Placer` that
carries out each step by pick-and-place
(:func:`~nsrmp_bench.generators.robot.pick_and_place.execute_step`) instead of a teleport;
pass it to :func:`~nsrmp_bench.generators.world.realise.realise`, which places the initial
scene as usual and runs every acceptance check, render and measurement. The rendering it
returns has ``executor="robot"``, the recorded :class:`Trajectory` and, in
``physics["robot"]``, every step's result (success, error to the symbolic target,
disturbance, simulated time) and the motion profile.
"""

from __future__ import annotations

import dataclasses
from typing import Final

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
from nsrmp_bench.generators.world.world import World
from nsrmp_bench.scene import Pose

__all__ = ["ROBOT_EXECUTOR", "RobotPlacer"]

ROBOT_EXECUTOR: Final = "robot"
"""The ``Rendering.executor`` value of robot-executed episodes."""


class RobotPlacer:
    """The Panda carries out every step by pick-and-place (motion ``profile``); the
    trajectory and every step's result are recorded into the rendering."""

    executor: Final = ROBOT_EXECUTOR
    moves_robot: Final = True

    def __init__(self, profile: str | MotionProfile = "fast") -> None:
        self.profile = get_profile(profile)
        self.results: list[StepResult] = []
        self._t = 0.0

    def begin(self, world: World) -> None:
        """Start an episode: no steps done, the clock at 0."""
        self.results = []
        self._t = 0.0

    def place(self, world: World, step: int, index: int, pose: Pose, lift: float) -> None:
        """Pick object ``index`` and place it at ``pose`` (``lift`` is a teleport's)."""
        result = execute_step(world, index, pose, self.profile, step_index=step, t0=self._t,
                              symbolic_target=pose)
        self._t += result.sim_time
        self.results.append(result)

    def finish(self, world: World, rendering: Rendering) -> Rendering:
        """``rendering`` with the trajectory and ``physics["robot"]``."""
        results = self.results
        trajectory = (concatenate_trajectories([r.trajectory for r in results]) if results
                      else empty_trajectory(robot_joint_names(world)))
        physics = dict(rendering.physics)
        physics["robot"] = {
            "executor_id": ROBOT_EXECUTOR_ID,
            "profile": self.profile.to_dict(),
            "success": all(r.success for r in results),
            "steps": [r.to_dict() for r in results],
            "sim_time": sum(r.sim_time for r in results),
        }
        return dataclasses.replace(rendering, executor=ROBOT_EXECUTOR, trajectory=trajectory,
                                   physics=physics)
