"""Replaying a prediction with the robot: what the Panda achieves when it carries it out.

:func:`replay_episode` puts an episode's initial scene into a :class:`World`, turns the
prediction into moves (:mod:`.plan`), executes each with the Panda
(:func:`~nsrmp_bench.generators.robot.pick_and_place.execute_step`) and measures the achieved
poses and amodal boxes after every executed step through the episode's camera.
:func:`achieved_prediction` turns the result into a prediction line for the normal
scorer: its boxes are the achieved final boxes, so a plan is judged by what the robot did.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.dsl.actions import target_pose
from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.episode import Episode, Trajectory
from nsrmp_bench.episode_views import episode_camera, episode_initial_state
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.generators.replay.plan import (
    SOURCES,
    PlannedMove,
    ReplayPlan,
    plan_from_boxes,
    plan_from_positions,
    plan_from_program,
)
from nsrmp_bench.generators.robot.pick_and_place import (
    SUCCESS,
    StepResult,
    SuccessCriterion,
    execute_step,
    poses_to_state,
    robot_joint_names,
)
from nsrmp_bench.generators.robot.profiles import MotionProfile, get_profile
from nsrmp_bench.generators.robot.recorder import (
    concatenate_trajectories,
    empty_trajectory,
)
from nsrmp_bench.generators.world.world import SettleResult, World
from nsrmp_bench.geometry.boxes import box_centres
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.scene import Pose, Scene, yaw_quaternion
from nsrmp_bench.scoring.submission import Prediction
from nsrmp_bench.vocabulary import TABLE_TOP_Z

__all__ = [
    "PredictedPlacement",
    "ReplayResult",
    "achieved_prediction",
    "make_plan",
    "placements_from_rows",
    "replay_episode",
    "stage_scene",
]

F64 = NDArray[np.float64]
_STAGE_LIFT = 0.0005  # m: objects are put this far above their initial pose, then settle


def stage_scene(world: World, scene: Scene) -> SettleResult:
    """Start ``scene``'s instance in ``world`` at its initial poses and let it settle."""
    world.begin(scene.objects)
    for i, pose in enumerate(scene.initial):
        world.place(i, pose, lift=_STAGE_LIFT)
    return world.settle()


@dataclass(frozen=True, eq=False)
class PredictedPlacement:
    """The parts of one prediction that say where objects go (any may be None)."""

    program: tuple[GroundedStep, ...] | None = None
    positions: NDArray[Any] | None = None
    boxes: NDArray[Any] | None = None
    pick: tuple[float, float] | None = None
    place: tuple[float, float] | None = None


def make_plan(camera: Camera, scene: Scene, prediction: PredictedPlacement,
              source: str = "auto") -> ReplayPlan:
    """The moves for ``prediction`` from ``source`` (``auto``: program, else positions,
    else boxes)."""
    if source not in SOURCES:
        msg = f"replay source {source!r} is not one of {list(SOURCES)}"
        raise InvalidArgument(msg)
    order = ("program", "positions", "boxes") if source == "auto" else (source,)
    for name in order:
        if name == "program" and prediction.program is not None:
            return plan_from_program(scene.objects, scene.initial, prediction.program)
        if name == "positions" and prediction.positions is not None:
            return plan_from_positions(scene.objects, scene.initial, prediction.positions)
        if name == "boxes" and prediction.boxes is not None:
            return plan_from_boxes(camera, scene.objects, scene.initial, prediction.boxes)
    have = [n for n in ("program", "positions", "boxes")
            if getattr(prediction, n) is not None]
    msg = (
        f"the prediction has no {' or '.join(order)} to replay (it has {have or 'nothing'}); "
        "choose another --source or add the field to the predictions file"
    )
    raise InvalidArgument(msg)


@dataclass(frozen=True, eq=False)
class ReplayResult:
    """What the robot achieved for one episode.

    ``poses`` ``(K+1, N, 7)`` and ``boxes`` ``(K+1, N, 4)`` hold the initial state and the
    state after each of the K executed moves.
    """

    episode_id: str
    plan: ReplayPlan
    steps: tuple[StepResult, ...]
    poses: F64
    boxes: F64
    trajectory: Trajectory
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        """Every executed move succeeded (an empty plan counts as a success)."""
        return all(s.success for s in self.steps)

    def summary(self) -> dict[str, Any]:
        """Plain JSON-able summary (no trajectory)."""
        return {
            "id": self.episode_id,
            "plan": self.plan.to_dict(),
            "success": self.success,
            "steps": [s.to_dict() for s in self.steps],
            **self.extra,
        }


def _move_target(world: World, scene: Scene, move: PlannedMove) -> Pose:
    """The move's target on the physical state now."""
    state = poses_to_state(world.poses())
    objects = scene.objects
    if move.step is not None:
        s = move.step
        return target_pose(objects, state, s.action, s.subject, s.reference)
    obj = objects[move.subject]
    x, y = move.xy
    if move.support < 0:
        z = TABLE_TOP_Z + obj.extents[2] / 2.0
    else:
        sup = state[move.support]
        if move.support_xy is not None:
            x += sup.position[0] - move.support_xy[0]
            y += sup.position[1] - move.support_xy[1]
        z = sup.position[2] + objects[move.support].extents[2] / 2.0 + obj.extents[2] / 2.0
    return Pose((x, y, z), yaw_quaternion(state[move.subject].yaw))


def _boxes(camera: Camera, scene: Scene, poses: F64) -> F64:
    ext = np.array([o.extents for o in scene.objects], dtype=np.float64).reshape(-1, 3)
    out: F64 = camera.amodal_boxes(ext, poses[:, :3], poses[:, 3:]).astype(np.float64)
    return out


def replay_episode(
    world: World,
    episode: Episode,
    prediction: PredictedPlacement,
    profile: str | MotionProfile = "fast",
    *,
    source: str = "auto",
    criterion: SuccessCriterion = SUCCESS,
    plan: ReplayPlan | None = None,
) -> ReplayResult:
    """Stage ``episode``'s initial scene, carry out ``prediction`` with the Panda, measure.

    ``plan`` replaces the plan made from ``prediction`` (e.g. an empty one: the robot
    does nothing).
    """
    prof = get_profile(profile)
    scene = episode_initial_state(episode)
    camera = episode_camera(episode)
    if plan is None:
        plan = make_plan(camera, scene, prediction, source)
    stage = stage_scene(world, scene)
    poses = [world.poses()]
    results: list[StepResult] = []
    t = 0.0
    for k, move in enumerate(plan.moves):
        target = _move_target(world, scene, move)
        result = execute_step(world, move.subject, target, prof, step_index=k, t0=t,
                              criterion=criterion)
        t += result.sim_time
        results.append(result)
        poses.append(world.poses())
    stacked = np.stack(poses)
    boxes = np.stack([_boxes(camera, scene, p) for p in stacked])
    traj = (concatenate_trajectories([r.trajectory for r in results]) if results
            else empty_trajectory(robot_joint_names(world)))
    extra = {"profile": prof.name, "staged_settled": stage.settled, "sim_time": t}
    return ReplayResult(episode.id, plan, tuple(results), stacked, boxes, traj, extra)


def achieved_prediction(result: ReplayResult, episode: Episode,
                        prediction: PredictedPlacement) -> Prediction:
    """The prediction line of what the robot achieved.

    ``boxes`` and ``positions`` are the achieved final ones. The predicted ``program`` is
    kept (it is the plan that was carried out). ``step_boxes`` are the boxes after each
    executed move when there are as many as the episode has steps. ``pick`` and ``place``
    (written when the prediction had them) are the centres of the first moved object's
    box before and after its move.
    """
    final_boxes = result.boxes[-1]
    n_moves = len(result.steps)
    step_boxes = (result.boxes[1:] if n_moves == episode.symbolic.num_steps and n_moves > 0
                  else None)
    pick = place = None
    if (prediction.pick is not None or prediction.place is not None) and n_moves:
        s = result.steps[0].subject
        cx, cy = box_centres(result.boxes[0, s])
        px, py = box_centres(result.boxes[1, s])
        pick = (float(cx), float(cy))
        place = (float(px), float(py))
    elif prediction.pick is not None or prediction.place is not None:
        pick, place = prediction.pick, prediction.place
    return Prediction(
        id=episode.id,
        boxes=final_boxes,
        program=prediction.program,
        step_boxes=step_boxes,
        pick=pick if prediction.pick is not None else None,
        place=place if prediction.place is not None else None,
        positions=result.poses[-1][:, :3],
    )


def placements_from_rows(
    program: Sequence[GroundedStep] | None,
    positions: NDArray[Any] | None,
    boxes: NDArray[Any] | None,
    pick: Sequence[float] | None,
    place: Sequence[float] | None,
) -> PredictedPlacement:
    """A :class:`PredictedPlacement` from plain values (NaN points count as absent)."""
    def point(v: Sequence[float] | None) -> tuple[float, float] | None:
        if v is None or not np.all(np.isfinite(np.asarray(v, dtype=np.float64))):
            return None
        return (float(v[0]), float(v[1]))

    return PredictedPlacement(
        program=None if program is None else tuple(program),
        positions=positions,
        boxes=boxes,
        pick=point(pick),
        place=point(place),
    )
