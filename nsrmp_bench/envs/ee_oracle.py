"""``oracle-ee``: the gold program carried out by end-effector actions (``control="ee"``).

A scripted, privileged policy that shows the end-effector mode is solvable: for each step
of the gold program (as the ``oracle`` baseline reads it) it plans the waypoints of the
robot executor's pick-and-place (:mod:`nsrmp_bench.generators.robot.pick_and_place`: the
same grasp yaw, travel height and release rules) on the *current* physical state, and
moves the hand towards them at most :data:`TRAVEL` (horizontally) or :data:`VERTICAL` (up
and down) per control step: up to the travel height, over the subject, down, close (held
:data:`CLOSE_STEPS` steps), up; then, reading where the object sits in the hand (as a
wrist camera would), over the target, down, open, up. It reads the environment's state
(the objects' poses and the gold program): an upper bound, like ``oracle``, never a model.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.errors import InvalidArgument

__all__ = ["CLOSE_STEPS", "TRAVEL", "VERTICAL", "OracleEEPolicy"]

F64 = NDArray[np.float64]

TRAVEL: Final = 0.05  # m per control step, horizontally (the mode's limit)
VERTICAL: Final = 0.02  # m per control step, up and down near the objects
CLOSE_STEPS: Final = 3  # control steps the closing hand waits (0.3 s at 10 Hz)
OPEN_STEPS: Final = 2
_TRAVEL_CLEARANCE: Final = 0.03  # as the robot executor
_MIN_LIFT: Final = 0.06
_RETREAT: Final = 0.06
_AT: Final = 1e-9


@dataclass
class _Waypoint:
    position: F64
    yaw: float
    gripper: float
    speed: float
    hold: int = 0  # control steps to stay once there
    measure: bool = False  # after reaching: plan the placing from the hand's grip


class OracleEEPolicy:
    """The scripted end-effector oracle (see the module)."""

    def __init__(self, env: Any) -> None:
        self.env = env.unwrapped
        if getattr(self.env, "control", None) != "ee":
            msg = ("policy 'oracle-ee' issues end-effector actions: make the environment with "
                   "control='ee' (rollout: --control ee)")
            raise InvalidArgument(msg)
        self._steps: list[tuple[str, int, int]] = []
        self._k = 0
        self._plan: deque[_Waypoint] = deque()
        self._target = np.zeros(3)
        self._yaw = 0.0
        self._place: dict[str, Any] = {}

    def reset(self, observation: dict[str, Any], info: dict[str, Any]) -> None:
        """The gold program (as ``oracle``), and the hand where it starts."""
        from nsrmp_bench.baselines.registry import get_baseline, predict

        (prediction,) = predict(get_baseline("oracle"), [self.env.episode])
        self._steps = [(s.action, s.subject, s.reference) for s in prediction.program or ()]
        self._k = 0
        self._plan.clear()
        proprio = np.asarray(observation["proprio"], dtype=np.float64)
        self._target = proprio[:3].copy()
        self._yaw = float(proprio[3])

    # -- planning ------------------------------------------------------------------------
    def _state(self) -> Any:
        from nsrmp_bench.generators.robot.pick_and_place import poses_to_state

        return poses_to_state(self.env.object_poses())

    def _plan_pick(self) -> None:
        from nsrmp_bench.dsl.actions import target_pose
        from nsrmp_bench.generators.robot.ee_control import GRIPPER_OPEN
        from nsrmp_bench.generators.robot.grasp import (
            choose_grasp_yaw,
            grasp_height,
            obstacles,
            travel_height,
        )
        from nsrmp_bench.generators.robot.pick_and_place import RELEASE_GAP
        from nsrmp_bench.generators.world.world import PANDA_BASE

        action, subject, reference = self._steps[self._k]
        self._k += 1
        objects = self.env.episode.symbolic.scene.objects
        state = self._state()
        target = target_pose(objects, state, action, subject, reference)
        obj, pick = objects[subject], state[subject]
        others = obstacles(objects, state, exclude=(subject,))
        z_place_grasp = grasp_height(obj, target) + RELEASE_GAP
        plan = choose_grasp_yaw(obj, pick, target, others, others, PANDA_BASE, z_place_grasp)
        z_pick = grasp_height(obj, pick)
        hang = z_pick - (pick.position[2] - obj.extents[2] / 2.0)
        z_travel = max(travel_height(pick.position, target.position, others, hang,
                                     _TRAVEL_CLEARANCE),
                       z_pick + _MIN_LIFT, z_place_grasp + _MIN_LIFT)
        px, py = pick.position[0], pick.position[1]
        opened = min(1.0, plan.opening / GRIPPER_OPEN)
        up = max(z_travel, float(self._target[2]))
        self._plan.extend([
            _Waypoint(np.array([self._target[0], self._target[1], up]), self._yaw, opened,
                      VERTICAL),
            _Waypoint(np.array([px, py, up]), plan.pick_yaw, opened, TRAVEL),
            _Waypoint(np.array([px, py, z_travel]), plan.pick_yaw, opened, VERTICAL, hold=1),
            _Waypoint(np.array([px, py, z_pick]), plan.pick_yaw, opened, VERTICAL, hold=1),
            _Waypoint(np.array([px, py, z_pick]), plan.pick_yaw, 0.0, VERTICAL,
                      hold=CLOSE_STEPS),
            _Waypoint(np.array([px, py, z_travel]), plan.pick_yaw, 0.0, VERTICAL, hold=1,
                      measure=True),
        ])
        self._place = {"subject": subject, "target": target, "plan": plan, "others": others,
                       "z_travel": z_travel, "opened": opened}

    def _plan_place(self, proprio: F64) -> None:
        from nsrmp_bench.generators.robot.grasp import release_lift, wrap_angle
        from nsrmp_bench.generators.robot.pick_and_place import RELEASE_GAP

        p = self._place
        objects = self.env.episode.symbolic.scene.objects
        subject, target, plan = p["subject"], p["target"], p["plan"]
        obj = objects[subject]
        ee_pos = proprio[:3]
        held = self._state()[subject]
        offset = np.asarray(held.position) - ee_pos
        c0, s0 = math.cos(plan.pick_yaw), math.sin(plan.pick_yaw)
        local = np.array([c0 * offset[0] + s0 * offset[1], -s0 * offset[0] + c0 * offset[1]])
        rel_yaw = wrap_angle(held.yaw - plan.pick_yaw)
        place_yaw = target.yaw - rel_yaw
        place_yaw += round((plan.place_yaw - place_yaw) / (2.0 * math.pi)) * 2.0 * math.pi
        c1, s1 = math.cos(place_yaw), math.sin(place_yaw)
        tx, ty, tz = target.position
        ex = tx - (c1 * local[0] - s1 * local[1])
        ey = ty - (s1 * local[0] + c1 * local[1])
        bottom_rest = tz - obj.extents[2] / 2.0
        ez = bottom_rest + RELEASE_GAP + (ee_pos[2] - (held.position[2] - obj.extents[2] / 2.0))
        ez += release_lift((ex, ey), place_yaw, ez, plan.opening, p["others"])
        z_travel = max(p["z_travel"], ez + _MIN_LIFT)
        opened = p["opened"]
        self._plan.extend([
            _Waypoint(np.array([ex, ey, z_travel]), place_yaw, 0.0, TRAVEL, hold=1),
            _Waypoint(np.array([ex, ey, ez]), place_yaw, 0.0, VERTICAL, hold=1),
            _Waypoint(np.array([ex, ey, ez]), place_yaw, opened, VERTICAL, hold=OPEN_STEPS),
            _Waypoint(np.array([ex, ey, max(ez + _RETREAT, min(z_travel, ez + 2 * _RETREAT))]),
                      place_yaw, opened, VERTICAL),
        ])

    # -- acting --------------------------------------------------------------------------
    def _at(self, wp: _Waypoint) -> bool:
        return (float(np.abs(wp.position - self._target).max()) < _AT
                and abs(wp.yaw - self._yaw) < _AT)

    def __call__(self, observation: dict[str, Any]) -> dict[str, Any]:
        from nsrmp_bench.generators.robot.ee_control import MAX_YAW

        while True:
            if not self._plan:
                if self._k >= len(self._steps):
                    return {"done": 1}
                self._plan_pick()
            wp = self._plan[0]
            if self._at(wp) and wp.hold <= 0:
                self._plan.popleft()
                if wp.measure:
                    self._plan_place(np.asarray(observation["proprio"], dtype=np.float64))
                continue
            break
        move = np.clip(wp.position - self._target, -wp.speed, wp.speed)
        turn = float(np.clip(wp.yaw - self._yaw, -MAX_YAW, MAX_YAW))
        if float(np.abs(wp.position - self._target - move).max()) < _AT:
            move = wp.position - self._target
        if abs(wp.yaw - self._yaw - turn) < _AT:
            turn = wp.yaw - self._yaw
        self._target = self._target + move
        self._yaw += turn
        if self._at(wp):
            wp.hold -= 1
        return {"ee": [float(move[0]), float(move[1]), float(move[2]), turn],
                "gripper": wp.gripper, "done": 0}
