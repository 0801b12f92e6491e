"""Turn a symbolic episode into a physical, rendered one: place, settle, check, render.

:func:`realise` places the initial objects at their symbolic poses (a hair above, then
lets physics settle), then for each grounded step has its :class:`Placer` put the moved
object at its symbolic target pose and settles again. The :class:`TeleportPlacer` (the
default) teleports it there, a hair above; the robot's placer
(:class:`nsrmp_bench.generators.robot.realise.RobotPlacer`) has the Panda carry it. Every
state (the initial one and the one after each step) is rendered and measured, whichever
placer moved the objects. An instance is rejected with a
:class:`PhysicsRejection` whose ``reason`` is one of :data:`REJECTION_REASONS`:

* ``penetration``: a placed object overlaps another object (or the table) by more than
  ``Tolerances.penetration`` before any physics runs;
* ``off_table``: an object's centre left the table top (or the target lies off it);
* ``unsettled``: the objects did not come to rest within ``Tolerances.settle_max_steps``;
* ``fell``: a placed object ended more than ``Tolerances.placed`` away from its symbolic
  pose (it fell from a target in mid-air, slid off its support, ...);
* ``toppled``: an object tilted by more than ``Tolerances.tilt_deg`` (a stack or an object
  tipped over);
* ``disturbed``: an object that was not moved ended more than ``Tolerances.disturbed``
  (or ``Tolerances.disturbed_deg``) away from its symbolic pose;
* ``occluded``: an object's exposed visible fraction (``targets.py``: visible pixels over
  the part of its silhouette not covered by objects stacked on it) is below
  ``min_visible``.

The checks run in that order after every placement; the first failure is reported.
Per rendered state the settled poses, amodal and visible boxes, visible fractions and
centre depths are recorded, and ``Rendering.physics`` holds the settle statistics (steps
per state, drifts, tilts, penetration, smallest exposed fraction) and the thresholds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any, Final, Protocol

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.episode import ObjectTargets, Observations, Rendering
from nsrmp_bench.errors import GenerationError, InvalidArgument
from nsrmp_bench.generators.world.targets import frame_targets
from nsrmp_bench.generators.world.world import TABLE_HALF_SIZE, RenderedImages, World
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.scene import Pose, Scene, State
from nsrmp_bench.vocabulary import TABLE_TOP_Z

__all__ = [
    "DEFAULT_MIN_VISIBLE",
    "EXECUTOR",
    "REJECTION_REASONS",
    "PhysicsRejection",
    "Placer",
    "TeleportPlacer",
    "Tolerances",
    "realise",
    "tilt_deg",
]

EXECUTOR: Final = "teleport"
"""The ``Rendering.executor`` of teleport-and-settle episodes (:class:`TeleportPlacer`)."""
REJECTION_REASONS: Final = (
    "penetration", "off_table", "unsettled", "fell", "toppled", "disturbed", "occluded",
)
_BELOW_TABLE: Final = 0.005  # a centre this far below the table top has left the table
DEFAULT_MIN_VISIBLE: Final = 0.3
"""Smallest accepted exposed visible fraction of any object in any rendered state (an
object must show at least 30% of the part of its silhouette that its own stack leaves
uncovered)."""


class PhysicsRejection(GenerationError):
    """The physical realisation of an instance failed a check; resample the instance.

    ``reason`` is one of :data:`REJECTION_REASONS`; ``step`` the rendered state (0 is the
    initial placement, k the state after step k); ``object_index`` the offending object
    (scene order); ``value`` the measured quantity and ``threshold`` its limit.
    """

    def __init__(
        self,
        message: str,
        *,
        reason: str,
        step: int,
        object_index: int | None,
        value: float,
        threshold: float,
    ) -> None:
        super().__init__(message)
        self.reason = reason
        self.step = step
        self.object_index = object_index
        self.value = value
        self.threshold = threshold

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able record of the rejection."""
        return {"reason": self.reason, "step": self.step, "object": self.object_index,
                "value": self.value, "threshold": self.threshold, "message": str(self)}


@dataclass(frozen=True)
class Tolerances:
    """Placement and acceptance thresholds (metres, degrees, steps).

    ``lift``: objects are placed this far above their symbolic pose, then dropped;
    ``penetration``: largest overlap with another body accepted at placement;
    ``placed``: largest distance of a placed object from its symbolic pose once settled;
    ``disturbed`` / ``disturbed_deg``: largest move / turn of an object that was not moved;
    ``tilt_deg``: largest tilt of any object from upright;
    ``table_margin``: object centres must stay this far inside the table's edges;
    ``settle_max_steps``: physics steps (1/240 s) allowed for the objects to come to rest.
    """

    lift: float = 0.001
    penetration: float = 0.002
    placed: float = 0.01
    disturbed: float = 0.005
    disturbed_deg: float = 5.0
    tilt_deg: float = 10.0
    table_margin: float = 0.0
    settle_max_steps: int = 480

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form."""
        return asdict(self)


class Placer(Protocol):
    """How :func:`realise` carries out each step's placement (the initial scene is always
    placed by teleport); the checks, renders and measurements are the same for every placer.

    ``begin`` starts an episode, ``place`` puts the object ``index`` moved by step ``step``
    (0-based) at its symbolic target ``pose`` (``lift``: the drop height a teleport uses),
    and ``finish`` adds what the placer recorded to the episode's rendering.
    """

    @property
    def executor(self) -> str:
        """The ``Rendering.executor`` value of the episodes it realises."""
        ...

    @property
    def moves_robot(self) -> bool:
        """Whether it moves the Panda (which then needs its whole collision hulls:
        ``World.begin(..., robot_collision=...)``)."""
        ...

    def begin(self, world: World) -> None: ...

    def place(self, world: World, step: int, index: int, pose: Pose, lift: float) -> None: ...

    def finish(self, world: World, rendering: Rendering) -> Rendering: ...


class TeleportPlacer:
    """Teleport-and-settle: the moved object appears a hair above its target and drops."""

    executor: Final = EXECUTOR
    moves_robot: Final = False  # the arm stands at rest, clear of the workspace

    def begin(self, world: World) -> None:
        """Nothing to reset."""

    def place(self, world: World, step: int, index: int, pose: Pose, lift: float) -> None:
        """Teleport object ``index`` to ``pose``, ``lift`` above it."""
        world.place(index, pose, lift=lift)

    def finish(self, world: World, rendering: Rendering) -> Rendering:
        """The rendering as it is."""
        return rendering


def _label(scene: Scene, i: int) -> str:
    return f"object {i} ({scene.objects[i].label})"


def _acos_deg(c: NDArray[np.float64]) -> NDArray[np.float64]:
    """Degrees of ``arccos`` of values in [-1, 1], element by element through libm.

    ``np.arccos`` is not used: numpy dispatches it to SIMD kernels by CPU feature (SVML
    on AVX-512), whose last bits differ from libm's, and these angles reach stored physics
    reports and rejection decisions. ``math.acos`` is what numpy itself calls without
    AVX-512, so the bytes made on such machines stay; ``* (180 / pi)`` is ``np.degrees``.
    """
    flat = [math.acos(v) for v in np.asarray(c, dtype=np.float64).reshape(-1).tolist()]
    out = np.array(flat, dtype=np.float64).reshape(np.shape(c))
    return out * (180.0 / math.pi)


def tilt_deg(quat: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angle in degrees between each body's z axis and world z, for unit xyzw quaternions.

    Dispatch-invariant: the same bits whatever SIMD kernels numpy picks on this CPU.
    """
    x, y = quat[..., 0], quat[..., 1]
    c = np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0)
    return _acos_deg(c)


def _rotation_deg(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    dot = np.abs(np.sum(a * b, axis=-1))
    return 2.0 * _acos_deg(np.clip(dot, 0.0, 1.0))


def _state_array(state: State) -> NDArray[np.float64]:
    return np.array([[*p.position, *p.orientation] for p in state], dtype=np.float64).reshape(-1, 7)


def _check_on_table(scene: Scene, step: int, settled: NDArray[np.float64],
                    tol: Tolerances) -> None:
    hx, hy = TABLE_HALF_SIZE
    pos = settled[:, :3]
    out_x = np.abs(pos[:, 0]) - (hx - tol.table_margin)
    out_y = np.abs(pos[:, 1]) - (hy - tol.table_margin)
    below = (TABLE_TOP_Z - _BELOW_TABLE) - pos[:, 2]
    off = np.maximum(np.maximum(out_x, out_y), below)
    if (off > 0).any():
        i = int(np.argmax(off))
        msg = (f"state {step}: {_label(scene, i)} left the table: its centre is at "
               f"({pos[i, 0]:.3f}, {pos[i, 1]:.3f}, {pos[i, 2]:.3f}) m, outside the table top "
               f"|x| <= {hx}, |y| <= {hy}, z >= {TABLE_TOP_Z}; resample the instance")
        raise PhysicsRejection(msg, reason="off_table", step=step, object_index=i,
                               value=float(off[i]), threshold=0.0)


def _check_settled(
    scene: Scene,
    step: int,
    settled: NDArray[np.float64],
    symbolic: NDArray[np.float64],
    placed: Sequence[int],
    tol: Tolerances,
) -> dict[str, float]:
    """Raise a PhysicsRejection if the settled state breaks a check; return its stats."""
    _check_on_table(scene, step, settled, tol)
    pos = settled[:, :3]
    drift = np.linalg.norm(pos - symbolic[:, :3], axis=1)
    placed_mask = np.zeros(len(scene), dtype=bool)
    placed_mask[list(placed)] = True
    if placed_mask.any():
        d = np.where(placed_mask, drift, 0.0)
        if (d > tol.placed).any():
            i = int(np.argmax(d))
            msg = (f"state {step}: {_label(scene, i)} fell: it came to rest {d[i] * 1000:.1f} mm "
                   f"from its target ({', '.join(f'{v:.3f}' for v in symbolic[i, :3])}), more "
                   f"than the {tol.placed * 1000:.0f} mm allowed; resample the instance")
            raise PhysicsRejection(msg, reason="fell", step=step, object_index=i,
                                   value=float(d[i]), threshold=tol.placed)
    tilt = tilt_deg(settled[:, 3:7])
    if (tilt > tol.tilt_deg).any():
        i = int(np.argmax(tilt))
        msg = (f"state {step}: {_label(scene, i)} toppled: it is tilted by {tilt[i]:.1f} deg, "
               f"more than the {tol.tilt_deg} deg allowed; resample the instance")
        raise PhysicsRejection(msg, reason="toppled", step=step, object_index=i,
                               value=float(tilt[i]), threshold=tol.tilt_deg)
    rot = _rotation_deg(settled[:, 3:7], symbolic[:, 3:7])
    others = ~placed_mask
    if others.any():
        d = np.where(others, drift, 0.0)
        r = np.where(others, rot, 0.0)
        if (d > tol.disturbed).any() or (r > tol.disturbed_deg).any():
            moved = bool((d > tol.disturbed).any())
            i = int(np.argmax(d)) if moved else int(np.argmax(r))
            msg = (f"state {step}: {_label(scene, i)} was disturbed: it moved "
                   f"{d[i] * 1000:.2f} mm and turned {r[i]:.1f} deg from where it stood, more "
                   f"than the {tol.disturbed * 1000:.2f} mm / {tol.disturbed_deg} deg allowed; "
                   "resample the instance")
            raise PhysicsRejection(msg, reason="disturbed", step=step, object_index=i,
                                   value=float(d[i] if moved else r[i]),
                                   threshold=tol.disturbed if moved else tol.disturbed_deg)
    return {
        "max_drift_m": float(drift.max()) if drift.size else 0.0,
        "max_tilt_deg": float(tilt.max()) if tilt.size else 0.0,
        "max_rotation_deg": float(rot[others].max()) if others.any() else 0.0,
    }


def _check_penetration(
    scene: Scene, world: World, step: int, indices: Sequence[int], tol: Tolerances
) -> float:
    worst = 0.0
    for i, other, dist in world.contacts(indices):
        worst = min(worst, dist)
        if dist < -tol.penetration:
            what = "the table or robot" if other < 0 else _label(scene, other)
            msg = (f"state {step}: {_label(scene, i)} placed at its target overlaps {what} "
                   f"by {-dist * 1000:.1f} mm, more than the {tol.penetration * 1000:.0f} mm "
                   "allowed; the target is occupied: resample the instance")
            raise PhysicsRejection(msg, reason="penetration", step=step, object_index=i,
                                   value=float(-dist), threshold=tol.penetration)
    return -worst


def _check_target_on_table(scene: Scene, step: int, i: int, state: State) -> None:
    x, y, _ = state[i].position
    hx, hy = TABLE_HALF_SIZE
    if abs(x) > hx or abs(y) > hy:
        msg = (f"state {step}: the target of {_label(scene, i)} at ({x:.3f}, {y:.3f}) lies off "
               f"the table top |x| <= {hx}, |y| <= {hy}; resample the instance")
        raise PhysicsRejection(msg, reason="off_table", step=step, object_index=i,
                               value=max(abs(x) - hx, abs(y) - hy), threshold=0.0)


def realise(
    scene: Scene,
    states: Sequence[State],
    grounded: Sequence[GroundedStep],
    world: World,
    *,
    min_visible: float = DEFAULT_MIN_VISIBLE,
    camera: Camera | None = None,
    tolerances: Tolerances | None = None,
    render: bool = True,
    composite: bool = True,
    placer: Placer | None = None,
) -> Rendering:
    """Realise ``scene`` through the symbolic ``states`` (``len(grounded) + 1`` of them)
    in ``world``: place, settle, check, render and measure every state.

    ``grounded[k].subject`` is the object moved by step k; ``placer`` (default
    :class:`TeleportPlacer`) places it at its pose in ``states[k + 1]``. Raises
    :class:`PhysicsRejection` (reason recorded) when a check fails and
    :class:`InvalidArgument` when the inputs do not fit together.
    ``render=False`` skips the images (targets then hold NaN boxes) for physics-only runs.
    ``composite`` renders the objects over a cached image of the empty scene (3x faster;
    see :meth:`World.render`); ``composite=False`` renders every image in full.
    """
    placer = TeleportPlacer() if placer is None else placer
    tol = Tolerances() if tolerances is None else tolerances
    cam = world.camera if camera is None else camera
    n = len(scene)
    if len(states) != len(grounded) + 1:
        msg = (f"realise needs one state per rendered step (steps + 1): got {len(states)} states "
               f"for {len(grounded)} steps; pass the executor's .states and .grounded together")
        raise InvalidArgument(msg)
    for k, st in enumerate(states):
        if len(st) != n:
            msg = f"state {k} has {len(st)} poses for a scene of {n} objects"
            raise InvalidArgument(msg)
    for k, g in enumerate(grounded):
        if not 0 <= g.subject < n:
            msg = f"step {k + 1} moves object {g.subject}, but the scene has objects 0..{n - 1}"
            raise InvalidArgument(msg)
    if not 0.0 <= min_visible <= 1.0:
        msg = f"min_visible must be a fraction in [0, 1], got {min_visible}"
        raise InvalidArgument(msg)

    try:
        return _realise(scene, states, grounded, world, min_visible, cam, tol, render,
                        composite, placer, robot_collision=placer.moves_robot)
    except _NearRobot:
        # an object came near the arm: the same instance with the arm's hulls whole
        return _realise(scene, states, grounded, world, min_visible, cam, tol, render,
                        composite, placer, robot_collision=True)


class _NearRobot(Exception):
    """An instance begun with the arm's hulls reduced put an object near the arm."""


def _check_clear_of_robot(world: World) -> None:
    if not world.robot_collision and world.near_robot():
        raise _NearRobot


def _realise(scene: Scene, states: Sequence[State], grounded: Sequence[GroundedStep],
             world: World, min_visible: float, cam: Camera, tol: Tolerances, render: bool,
             composite: bool, placer: Placer, *, robot_collision: bool) -> Rendering:
    """:func:`realise` once its inputs are checked (``robot_collision``: see
    :meth:`World.begin`)."""
    n = len(scene)
    # the scenery is drawn only into the cached background: once cached, composite
    # renders hide it, so it is loaded without visuals (same physics, half the reset)
    world.begin(scene.objects,
                scenery_visuals=render and not (composite and world.has_background(cam)),
                robot_collision=robot_collision)
    placer.begin(world)
    if composite and render:
        world.prepare_background(cam)
    extents = np.array([o.extents for o in scene.objects], dtype=np.float64).reshape(n, 3)
    num = len(states)
    poses = np.empty((num, n, 7), dtype=np.float64)
    rgb = np.empty((num, cam.height, cam.width, 3), dtype=np.uint8) if render else None
    depth = np.empty((num, cam.height, cam.width), dtype=np.float32) if render else None
    seg = np.empty((num, cam.height, cam.width), dtype=np.int16) if render else None
    amodal = np.empty((num, n, 4), dtype=np.float32)
    visible = np.full((num, n, 4), np.nan, dtype=np.float32)
    fraction = np.full((num, n), np.nan, dtype=np.float32)
    centre = np.empty((num, n), dtype=np.float32)
    stats: dict[str, list[Any]] = {
        "settle_steps": [], "settled": [], "max_drift_m": [], "max_tilt_deg": [],
        "max_rotation_deg": [], "max_penetration_m": [], "min_visible_fraction": [],
    }
    with world.solver_iterations(world.config.settle_solver_iterations):
        for k in range(num):
            if k == 0:
                placed = list(range(n))
                for i in placed:
                    world.place(i, states[0][i], lift=tol.lift)
            else:
                subject = grounded[k - 1].subject
                placed = [subject]
                _check_target_on_table(scene, k, subject, states[k])
                placer.place(world, k - 1, subject, states[k][subject], tol.lift)
            _check_clear_of_robot(world)
            pen = _check_penetration(scene, world, k, placed, tol)
            result = world.settle(max_steps=tol.settle_max_steps,
                                  floor_z=TABLE_TOP_Z - _BELOW_TABLE - 0.1)
            _check_clear_of_robot(world)
            settled = world.poses()
            if not result.settled:
                _check_on_table(scene, k, settled, tol)
                msg = (f"state {k}: the objects did not come to rest within {result.steps} "
                       f"steps (fastest object still at {result.max_linear_speed:.4f} m/s, "
                       f"{result.max_angular_speed:.3f} rad/s); resample the instance")
                raise PhysicsRejection(msg, reason="unsettled", step=k, object_index=None,
                                       value=result.max_linear_speed, threshold=0.0)
            checks = _check_settled(scene, k, settled, _state_array(states[k]), placed, tol)
            poses[k] = settled
            min_frac: float | None = None
            if render:
                assert rgb is not None and depth is not None and seg is not None
                images = world.render(cam, composite=composite,
                                      out=RenderedImages(rgb[k], depth[k], seg[k]))
                ft = frame_targets(cam, scene.objects, settled, images.segmentation)
                visible[k] = ft.boxes_visible
                fraction[k] = ft.visible_fraction
                if n:
                    i = int(np.argmin(ft.exposed_fraction))
                    min_frac = float(ft.exposed_fraction[i])
                    if min_frac < min_visible:
                        msg = (f"state {k}: {_label(scene, i)} is only {min_frac:.0%} visible "
                               f"({int(ft.visible_pixels[i])} px of the "
                               f"~{ft.silhouette_area[i]:.0f} px of its silhouette; objects "
                               f"stacked on it do not count), below the {min_visible:.0%} "
                               "required; resample the instance")
                        raise PhysicsRejection(msg, reason="occluded", step=k, object_index=i,
                                               value=min_frac, threshold=min_visible)
                amodal[k] = ft.boxes_amodal
                centre[k] = ft.depth_centre
            else:
                amodal[k] = cam.amodal_boxes(extents, settled[:, :3], settled[:, 3:7])
                centre[k] = cam.project(settled[:, :3])[1].astype(np.float32)
            stats["settle_steps"].append(result.steps)
            stats["settled"].append(result.settled)
            stats["max_drift_m"].append(checks["max_drift_m"])
            stats["max_tilt_deg"].append(checks["max_tilt_deg"])
            stats["max_rotation_deg"].append(checks["max_rotation_deg"])
            stats["max_penetration_m"].append(pen)
            stats["min_visible_fraction"].append(min_frac)
    physics: dict[str, Any] = {
        **stats,
        "total_steps": int(sum(stats["settle_steps"])),
        "tolerances": tol.to_dict(),
        "min_visible": min_visible,
        "world": world.config.to_dict(),
    }
    observations = (
        Observations(rgb=rgb, depth=depth, segmentation=seg)
        if rgb is not None and depth is not None and seg is not None else None
    )
    targets = ObjectTargets(
        poses=poses,
        boxes_amodal=amodal,
        boxes_visible=visible,
        visible_fraction=fraction,
        depth_centre=centre,
    )
    return placer.finish(world, Rendering(camera=cam, observations=observations,
                                          targets=targets, executor=placer.executor,
                                          trajectory=None, physics=physics))
