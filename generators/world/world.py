"""The PyBullet world: one DIRECT client per process, a table, a Franka Panda, the objects.

A :class:`World` is built once per process and reused for every instance, but every
instance starts from a freshly reset simulation: :meth:`World.begin` resets the client
(``resetSimulation``), reloads the table and the Panda and creates one body per object of
the scene, in scene order. Nothing of an earlier instance survives into the next.

An instance begun without scenery visuals (teleport-and-settle once the empty scene is
cached) is simulated in a second client whose renderer is off, so its reset builds no
render meshes; its composite renders are drawn by the objects' render twin, a third
client that is never reset and keeps its bodies from one instance to the next
(:mod:`~nsrmp_bench.generators.world.object_twin`; the same bytes).

Determinism (same inputs give the same bytes whatever the process did before; tests
realise episodes after other episodes, in shuffled orders and in subprocesses, and
compare them):

* Bullet keeps history in state no call clears: the broadphase's trees, its pair-cleanup
  cursor and the order of its pair cache and contact manifolds. Taking bodies out of the
  collision world and putting them back (the v1 world) left that state behind, and an
  episode realised after another one differed in its last bits from the same episode
  realised first (objects-v1/test 000643 after 000642; the v1 splits were withdrawn for
  it). The reset costs
  ~30 ms per instance (``benchmarks/bench_generate.py``); it is the price of a split that
  is the same bytes whatever the shard size, worker count or order of generation;
* objects are reduced-coordinate multibodies, like the table and the robot, so all
  contacts go through one solver path;
* collision groups keep the scenery and the robot from forming pairs with each other
  (see ``GROUP_*``): the arm sways a little under its motors, and pairs appearing and
  vanishing there would reorder the solver's contact list;
* overlapping pairs are processed in sorted order (``deterministicOverlappingPairs``),
  the solver runs its full iteration count and sleeping is disabled.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from types import ModuleType
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench._optional import require
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.generators.world.assets import (
    OBJECT_DYNAMICS,
    ShapeIds,
    asset_cache_dir,
    create_shape_ids,
    ensure_dice_textures,
    lean_panda_urdf,
    physics_urdf,
)
from nsrmp_bench.generators.world.object_twin import (
    ObjectTwin,
    object_look,
    physics_only_client,
)
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.geometry.default_camera import OFFICIAL_CAMERA
from nsrmp_bench.scene import Pose, SceneObject
from nsrmp_bench.vocabulary import TABLE_TOP_Z

__all__ = [
    "GROUP_OBJECT",
    "GROUP_ROBOT",
    "GROUP_SCENERY",
    "PANDA_BASE",
    "PANDA_REST",
    "TABLE_HALF_SIZE",
    "RenderedImages",
    "SettleResult",
    "World",
    "WorldConfig",
]

PANDA_BASE: Final = (0.0, 0.50, TABLE_TOP_Z)
"""The Panda's base: on the table's far edge (+y), facing the camera (-y)."""
PANDA_REST: Final = (0.0, -1.5, 0.0, -2.6, 0.0, 1.1, 0.785)
"""Arm joints of the rest pose: folded up and back, clear of the workspace."""
PANDA_FINGERS: Final = 0.02
TABLE_HALF_SIZE: Final = (0.75, 0.50)
"""Half sizes (x, y) of the table top, centred on the origin."""

# Collision groups: the static scenery (table, floor), the objects and the robot. Scenery
# and robot collide only with objects, so they never form contact pairs among themselves;
# such pairs come and go as the arm sways and would reorder the solver's contacts from
# one instance to the next (a determinism leak measured in tests/world).
GROUP_SCENERY: Final = 1
GROUP_OBJECT: Final = 2
GROUP_ROBOT: Final = 4
ROBOT_CLEARANCE: Final = 0.05
"""Metres between the objects' and the resting Panda's bounding boxes that an instance
begun with ``robot_collision=False`` keeps (:meth:`World.near_robot`); Bullet's contact
margins and breaking threshold are a few centimetres at most."""
_PARK_ORIGIN: Final = (50.0, 50.0, -20.0)
_PARK_SPACING: Final = 2.0


@dataclass(frozen=True)
class WorldConfig:
    """How the world is built. The defaults are the official, measured-fast variant.

    ``panda``: ``"lean"`` (collision meshes as visuals; 3.5k triangles), ``"stock"``
    (pybullet_data's visual meshes; 103k triangles: +19 ms per full 320x240 render, twice
    the cost) or ``"none"``. ``floor``: load ``plane.urdf`` (+21 ms per full 320x240
    render, for pixels around the table). ``background``: RGB of pixels that show no body.
    Measured breakdown: ``benchmarks/bench_render.py --breakdown``.
    ``solver_iterations`` is the world's default (grasping needs it: fewer than 20 lose
    grasps, perf-limits §4); teleport-and-settle runs with ``settle_solver_iterations``
    (measured: 30 instead of 50 cuts settling CPU by 28% with the same rejections and
    drifts below 0.14 mm).
    """

    panda: str = "lean"
    floor: bool = False
    time_step: float = 1.0 / 240.0
    solver_iterations: int = 50
    solver_residual_threshold: float = 0.0
    settle_solver_iterations: int = 30
    background: tuple[int, int, int] = (206, 214, 222)
    light_direction: tuple[float, float, float] = (0.4, -0.6, 1.0)
    shadow: bool = False

    def __post_init__(self) -> None:
        if self.panda not in ("lean", "stock", "none"):
            msg = f"WorldConfig.panda must be 'lean', 'stock' or 'none', got {self.panda!r}"
            raise InvalidArgument(msg)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form (stored with every rendering)."""
        out: dict[str, Any] = {
            "panda": self.panda,
            "floor": self.floor,
            "time_step": self.time_step,
            "solver_iterations": self.solver_iterations,
            "settle_solver_iterations": self.settle_solver_iterations,
            "background": list(self.background),
            "light_direction": list(self.light_direction),
            "shadow": self.shadow,
        }
        if self.solver_residual_threshold != 0.0:  # recorded only when changed, so
            # data generated before the field existed keeps its hashes
            out["solver_residual_threshold"] = self.solver_residual_threshold
        return out


@dataclass(frozen=True, eq=False)
class RenderedImages:
    """One render: RGB ``(H, W, 3)`` uint8, depth ``(H, W)`` float32 metres, segmentation
    ``(H, W)`` int16 object index (-1 for table, robot and background)."""

    rgb: NDArray[np.uint8]
    depth: NDArray[np.float32]
    segmentation: NDArray[np.int16]


@dataclass
class SettleResult:
    """How a settle ended: steps taken, whether everything came to rest, last speeds."""

    steps: int
    settled: bool
    max_linear_speed: float
    max_angular_speed: float
    extra: dict[str, float] = field(default_factory=dict)


def _check_out(out: RenderedImages, cam: Camera) -> None:
    """Raise unless ``out`` holds arrays a ``cam`` render can be written into."""
    h, w = cam.height, cam.width
    want = (("rgb", (h, w, 3), np.uint8), ("depth", (h, w), np.float32),
            ("segmentation", (h, w), np.int16))
    for name, shape, dtype in want:
        arr = getattr(out, name)
        if arr.shape != shape or arr.dtype != dtype or not arr.flags.writeable:
            msg = (f"World.render(out=...): out.{name} is a {arr.dtype} array of shape "
                   f"{arr.shape}{'' if arr.flags.writeable else ', read-only'}; expected "
                   f"a writeable {np.dtype(dtype)} array of shape {shape} for a {w}x{h} "
                   "camera; pass arrays of that camera's size or leave out= unset")
            raise InvalidArgument(msg)


@lru_cache(maxsize=32)
def _gl_matrices(camera: Camera) -> tuple[list[float], list[float]]:
    return camera.view_matrix_gl, camera.projection_matrix_gl_pixel_centred


class World:
    """A PyBullet DIRECT client with the table, the Panda and the objects of an instance.

    Build one per process and reuse it for every instance; :meth:`begin` resets the
    simulation and builds the instance's scene from nothing. Use as a context manager or
    call :meth:`close`.

    ``lean_reset`` (the default) makes that reset cheaper with the same bytes: the lean
    Panda's collision meshes are read from copies that hold only what the collision import
    reads (:func:`~nsrmp_bench.generators.world.assets.collision_obj`) and
    ``begin(..., scenery_visuals=False)`` is honoured. ``lean_reset=False`` is the reset as
    it was (every file as shipped, every visual loaded), kept to measure the difference
    (``benchmarks/bench_generate.py``).

    ``object_twin`` (the default; only with ``lean_reset``) simulates an instance begun
    without scenery visuals in a second client whose renderer is off, and draws its
    composite renders in a third that keeps the objects' bodies from one instance to the
    next (:mod:`~nsrmp_bench.generators.world.object_twin`): the reset then builds no
    render meshes, with the same bytes. :attr:`client` is the physics client of the
    current instance.
    """

    def __init__(
        self,
        camera: Camera | None = None,
        *,
        config: WorldConfig | None = None,
        cache_dir: str | Path | None = None,
        lean_reset: bool = True,
        object_twin: bool = True,
    ) -> None:
        self.pb: ModuleType = require("pybullet")
        self._cv2: ModuleType = require("cv2")
        pybullet_data = require("pybullet_data")
        self.camera = OFFICIAL_CAMERA if camera is None else camera
        self.config = WorldConfig() if config is None else config
        self._data_path = pybullet_data.getDataPath()
        self._assets = asset_cache_dir(cache_dir)
        self._texture_files = ensure_dice_textures(self._assets)
        self.lean_reset = lean_reset
        self.object_twin = object_twin and lean_reset
        lean = self.config.panda == "lean"
        self._panda_urdf = (str(lean_panda_urdf(self._assets, self._data_path,
                                                lean_collision=lean_reset))
                            if lean else "franka_panda/panda.urdf")
        # the arm of an instance begun without scenery visuals, by (loaded in the
        # physics-only client, hulls reduced to their bounds: begin's robot_collision):
        # where a renderer could draw it, 1 mm boxes for visuals (with
        # URDF_IGNORE_VISUAL_SHAPES PyBullet would tessellate the hulls instead); in the
        # physics-only client, which draws nothing, no visuals at all
        self._bare_panda_urdfs: dict[tuple[bool, bool], str] = {}
        if lean and lean_reset:
            for bounds in (False, True):
                stand_ins = lean_panda_urdf(self._assets, self._data_path, visuals=False,
                                            bounds=bounds)
                self._bare_panda_urdfs[False, bounds] = str(stand_ins)
                if self.object_twin:
                    self._bare_panda_urdfs[True, bounds] = str(physics_urdf(stand_ins,
                                                                            self._assets))
        # the table of an instance begun without scenery visuals: no visuals to parse
        self._bare_table_urdf = (
            str(physics_urdf(Path(self._data_path) / "table" / "table.urdf", self._assets))
            if lean_reset else "table/table.urdf")
        pb = self.pb
        self.client: int = pb.connect(pb.DIRECT)
        if self.client < 0:
            msg = "PyBullet could not start a DIRECT client"
            raise RuntimeError(msg)
        self._full_client = self.client  # renders: instances begun with scenery visuals
        self._lean_client: int | None = None  # physics only: the twin draws its objects
        self._twin: ObjectTwin | None = None
        self._closed = False
        self.plane: int | None = None
        self.table: int = -1
        self.panda: int | None = None
        self._panda_arm: list[int] = []
        self._panda_fingers: list[int] = []
        self.bodies: tuple[int, ...] = ()  # bodies of the current instance, in scene order
        self.objects: tuple[SceneObject, ...] = ()
        self._seg_lut = np.full(1, -1, dtype=np.int16)
        self._scenery: tuple[tuple[int, int, tuple[float, ...]], ...] = ()
        self._fills: dict[tuple[int, int], NDArray[np.uint8]] = {}
        # Renders of the empty scene per camera. Every build is the same, so they stay
        # valid from one instance to the next (render(composite=True)).
        self._scenery_cache: dict[Camera, RenderedImages] = {}
        self._scenery_visuals = True
        # (scenery_visuals, robot_collision) of the scenery already built and untouched
        # since (prime()): the next begin() with the same build adds only the objects
        self._pristine: tuple[bool, bool] | None = None
        self.robot_collision = True  # the arm's hulls as shipped (see begin)
        # the Panda's link boxes (min, max corners) at rest, read the first time it loads:
        # what an instance begun with robot_collision=False keeps clear of (near_robot())
        self._robot_boxes: NDArray[np.float64] | None = None
        self.begin(())

    # -- construction ------------------------------------------------------------------
    def _build_scenery(self, visuals: bool, robot_collision: bool = True) -> None:
        """Reset the simulation and load the floor, the table and the Panda; their visual
        shapes only when ``visuals``, the arm's hulls whole only when ``robot_collision``
        (see :meth:`begin`)."""
        pb, c = self.pb, self.client
        flags = 0 if visuals else pb.URDF_IGNORE_VISUAL_SHAPES
        pb.resetSimulation(physicsClientId=c)
        pb.setAdditionalSearchPath(self._data_path, physicsClientId=c)
        pb.setGravity(0.0, 0.0, -9.81, physicsClientId=c)
        pb.setPhysicsEngineParameter(
            fixedTimeStep=self.config.time_step,
            numSolverIterations=self.config.solver_iterations,
            numSubSteps=0,
            deterministicOverlappingPairs=1,
            solverResidualThreshold=self.config.solver_residual_threshold,
            physicsClientId=c,
        )
        self.plane = None
        if self.config.floor:
            self.plane = pb.loadURDF("plane.urdf", [0.0, 0.0, 0.0], useFixedBase=True,
                                     flags=flags, physicsClientId=c)
        self.table = pb.loadURDF("table/table.urdf" if visuals else self._bare_table_urdf,
                                 [0.0, 0.0, 0.0], useFixedBase=True, flags=flags,
                                 physicsClientId=c)
        for static in (self.plane, self.table):
            if static is not None:
                pb.setCollisionFilterGroupMask(static, -1, GROUP_SCENERY, GROUP_OBJECT,
                                               physicsClientId=c)
        self.panda = None
        self._panda_arm = []
        self._panda_fingers = []
        self.robot_collision = True
        if self.config.panda != "none":
            self._load_panda(flags, robot_collision)
        self._scenery_visuals = visuals
        # visual shapes of the table, floor and robot: (body, link, rgba), hidden while
        # the objects are rendered over a cached empty scene (render(composite=True));
        # none in the physics-only client, which never renders
        self._scenery = () if c == self._lean_client else tuple(
            (int(d[0]), int(d[1]), tuple(float(v) for v in d[7]))
            for b in (self.plane, self.table, self.panda) if b is not None
            for d in pb.getVisualShapeData(b, physicsClientId=c))

    def _load_panda(self, flags: int, robot_collision: bool = True) -> None:
        pb, c = self.pb, self.client
        orn = pb.getQuaternionFromEuler([0.0, 0.0, -math.pi / 2.0])
        urdf = self._panda_urdf
        if flags & pb.URDF_IGNORE_VISUAL_SHAPES and self._bare_panda_urdfs:
            physics_only = c == self._lean_client
            urdf = self._bare_panda_urdfs[physics_only, not robot_collision]
            self.robot_collision = robot_collision
            if not physics_only:  # the stand-ins are drawn instead of the hulls
                flags &= ~pb.URDF_IGNORE_VISUAL_SHAPES
        body = pb.loadURDF(urdf, list(PANDA_BASE), orn, useFixedBase=True, flags=flags,
                           physicsClientId=c)
        self.panda = int(body)
        for link in range(-1, pb.getNumJoints(body, physicsClientId=c)):
            pb.setCollisionFilterGroupMask(body, link, GROUP_ROBOT, GROUP_OBJECT,
                                           physicsClientId=c)
        for j in range(pb.getNumJoints(body, physicsClientId=c)):
            info = pb.getJointInfo(body, j, physicsClientId=c)
            name = info[1].decode()
            if info[2] == pb.JOINT_REVOLUTE:
                self._panda_arm.append(j)
            elif info[2] == pb.JOINT_PRISMATIC and "finger" in name:
                self._panda_fingers.append(j)
        if self.config.panda == "lean" and urdf == self._panda_urdf and not (
                flags & pb.URDF_IGNORE_VISUAL_SHAPES):
            # two-tone look of the real arm
            dark = [0.25, 0.26, 0.28, 1.0]
            light = [0.93, 0.93, 0.93, 1.0]
            for link in range(-1, pb.getNumJoints(body, physicsClientId=c)):
                name = (pb.getBodyInfo(body, physicsClientId=c)[0].decode() if link < 0 else
                        pb.getJointInfo(body, link, physicsClientId=c)[12].decode())
                colour = dark if any(k in name for k in ("hand", "finger", "link0")) else light
                pb.changeVisualShape(body, link, rgbaColor=colour, physicsClientId=c)
        self.reset_panda()
        if self._robot_boxes is None:
            self._robot_boxes = np.array(
                [pb.getAABB(body, link, physicsClientId=c)
                 for link in range(-1, pb.getNumJoints(body, physicsClientId=c))],
                dtype=np.float64)

    def _create_objects(self, objects: Sequence[SceneObject], visuals: bool) -> list[int]:
        """One body per object, in scene order, coloured (without a visual shape unless
        ``visuals``), parked far apart below the floor (colliding with nothing there)
        until :meth:`place`."""
        pb, c = self.pb, self.client
        shapes: dict[str, ShapeIds] = {}
        textures: dict[str, int] = {}
        bodies: list[int] = []
        for slot, obj in enumerate(objects):
            if obj.shape not in shapes:
                shapes[obj.shape] = create_shape_ids(pb, c, obj.shape, visual=visuals)
            park = (_PARK_ORIGIN[0] + _PARK_SPACING * slot, _PARK_ORIGIN[1], _PARK_ORIGIN[2])
            body = int(pb.createMultiBody(
                baseMass=OBJECT_DYNAMICS["mass"],
                baseCollisionShapeIndex=shapes[obj.shape].collision,
                baseVisualShapeIndex=shapes[obj.shape].visual if visuals else -1,
                basePosition=park,
                useMaximalCoordinates=False,
                physicsClientId=c,
            ))
            pb.changeDynamics(
                body, -1,
                lateralFriction=OBJECT_DYNAMICS["lateralFriction"],
                spinningFriction=OBJECT_DYNAMICS["spinningFriction"],
                rollingFriction=OBJECT_DYNAMICS["rollingFriction"],
                restitution=OBJECT_DYNAMICS["restitution"],
                linearDamping=OBJECT_DYNAMICS["linearDamping"],
                angularDamping=OBJECT_DYNAMICS["angularDamping"],
                activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING,
                physicsClientId=c,
            )
            pb.setCollisionFilterGroupMask(body, -1, GROUP_OBJECT,
                                           GROUP_SCENERY | GROUP_OBJECT | GROUP_ROBOT,
                                           physicsClientId=c)
            if visuals:
                texture, rgba = object_look(obj)
                if texture is None:
                    pb.changeVisualShape(body, -1, rgbaColor=list(rgba), physicsClientId=c)
                else:
                    if texture not in textures:
                        textures[texture] = int(pb.loadTexture(
                            str(self._texture_files[texture]), physicsClientId=c))
                    pb.changeVisualShape(body, -1, textureUniqueId=textures[texture],
                                         rgbaColor=list(rgba), physicsClientId=c)
            bodies.append(body)
        return bodies

    # -- instance lifecycle --------------------------------------------------------------
    def reset_panda(self) -> None:
        """Put the Panda in its rest pose, at rest, holding it with position control."""
        self._pristine = None
        if self.panda is None:
            return
        pb, c, body = self.pb, self.client, self.panda
        for j, q in zip(self._panda_arm, PANDA_REST, strict=True):
            pb.resetJointState(body, j, q, 0.0, physicsClientId=c)
        for j in self._panda_fingers:
            pb.resetJointState(body, j, PANDA_FINGERS, 0.0, physicsClientId=c)
        joints = self._panda_arm + self._panda_fingers
        targets = list(PANDA_REST) + [PANDA_FINGERS] * len(self._panda_fingers)
        pb.setJointMotorControlArray(body, joints, pb.POSITION_CONTROL, targetPositions=targets,
                                     forces=[200.0] * len(joints), physicsClientId=c)

    def begin(self, objects: Sequence[SceneObject], *,
              scenery_visuals: bool = True, robot_collision: bool = True) -> tuple[int, ...]:
        """Start an instance with ``objects``: reset the simulation, rebuild the table and
        the Panda (at rest) and create the objects' bodies, parked until :meth:`place`.

        Returns the bodies in scene order. Parked bodies keep falling (far away, colliding
        with nothing) rather than being put to sleep, as sleeping and waking bodies was
        measured to leak history into the results.

        ``scenery_visuals=False`` loads the table, floor and Panda without their own
        visual shapes (``URDF_IGNORE_VISUAL_SHAPES``; the table and, in the physics-only
        client of ``object_twin``, the arm from copies of their files with no visuals to
        parse, :func:`~nsrmp_bench.generators.world.assets.physics_urdf`): the same
        bodies, collision shapes and physics, drawn with plain stand-ins that PyBullet
        makes from the collision shapes where a renderer draws them. A composite render
        over a cached background hides the scenery anyway, so its pixels are the same,
        and the reset no longer decodes the table's 0.9 MB texture five times (measured:
        the table's load drops from ~45% of the reset to ~1%). Full renders and
        :meth:`prepare_background` raise until the next ``begin`` with visuals. Ignored
        (visuals always loaded) when ``lean_reset`` is off.

        ``robot_collision=False`` (with ``scenery_visuals=False``) builds each of the arm's
        collision hulls from the six points that bound it
        (:func:`~nsrmp_bench.generators.world.assets.bounding_points_obj`) instead of
        every point of its mesh: for teleport-and-settle, where the arm stands folded at
        rest, clear of the workspace, and touches nothing. Its links keep their bounding
        boxes to the bit, so the broadphase, the only part of Bullet that sees an arm no
        object touches, is the same (the same bytes on every committed part;
        ``docs/performance.md``), and the reset skips most of the hull computation, its
        costliest part. :meth:`near_robot` says whether the objects came near the arm;
        realising then starts again with its hulls whole. Ignored (hulls whole) with
        scenery visuals or without ``lean_reset``.
        """
        visuals = self._use_client(scenery_visuals)
        build = (visuals, robot_collision or visuals)
        if self._pristine != build:
            self._build_scenery(*build)
        self._pristine = None
        bodies = self._create_objects(objects, visuals=not self._twin_draws)
        n = self.pb.getNumBodies(physicsClientId=self.client)
        self._seg_lut = np.full(n + 2, -1, dtype=np.int16)  # entry 0: PyBullet's -1
        for i, body in enumerate(bodies):
            self._seg_lut[body + 1] = i
        self.bodies = tuple(bodies)
        self.objects = tuple(objects)
        if self._twin_draws:
            assert self._twin is not None
            self._twin.assign(objects)
        return self.bodies

    def _use_client(self, scenery_visuals: bool) -> bool:
        """Switch :attr:`client` to the one an instance with(out) ``scenery_visuals``
        runs in: the physics-only client where the twin draws it (``object_twin``), else
        the world's own. Returns whether the scenery gets its visuals."""
        visuals = scenery_visuals or not self.lean_reset
        client = self._full_client
        if not visuals and self.object_twin:
            if self._lean_client is None:
                self._lean_client = physics_only_client(self.pb)
                self._twin = ObjectTwin(self.pb, self._texture_files)
            client = self._lean_client
        if client != self.client:
            self.client = client
            self._pristine = None
        return visuals

    @property
    def _twin_draws(self) -> bool:
        """Whether the current instance's composite renders are drawn by the twin."""
        return self._twin is not None and self.client == self._lean_client

    @property
    def render_client(self) -> int:
        """The client the current instance's composite renders are drawn in: the render
        twin's for an instance begun without scenery visuals (``object_twin``), else
        :attr:`client`."""
        if self._twin_draws:
            assert self._twin is not None
            return self._twin.client
        return self.client

    @property
    def twin(self) -> ObjectTwin | None:
        """The objects' render twin, once an instance has used it (``object_twin``)."""
        return self._twin

    def prime(self, *, scenery_visuals: bool = False) -> None:
        """Reset the simulation and build the scenery (the first half of :meth:`begin`),
        so that the next ``begin`` with the same ``scenery_visuals`` only adds the objects.

        The state left is the one every ``begin`` starts the objects from; a process forked
        here (:mod:`~nsrmp_bench.generators.world.template`) starts each instance from it
        without reloading the table and the Panda. Placing, stepping or settling in between
        voids it: the next ``begin`` then resets as usual.
        """
        visuals = self._use_client(scenery_visuals)
        self._build_scenery(visuals)
        self._pristine = (visuals, True)

    @property
    def primed(self) -> bool:
        """Whether the scenery is as :meth:`prime` built it, untouched since."""
        return self._pristine is not None

    def near_robot(self, margin: float = ROBOT_CLEARANCE) -> bool:
        """Whether an object's bounding box comes within ``margin`` metres of a box of the
        Panda's links at rest: where an instance begun with ``robot_collision=False``
        could touch the arm, whose reduced hulls would then not be its own. False when the
        Panda was never loaded (``panda="none"``)."""
        boxes = self._robot_boxes
        if boxes is None or not self.bodies:
            return False
        pb, c = self.pb, self.client
        objs = np.array([pb.getAABB(b, -1, physicsClientId=c) for b in self.bodies],
                        dtype=np.float64)  # (N, 2, 3)
        lo = objs[:, None, 0] - margin  # (N, 1, 3) against (1, L, 3)
        hi = objs[:, None, 1] + margin
        apart = (lo > boxes[None, :, 1]) | (hi < boxes[None, :, 0])
        return bool((~apart.any(-1)).any())

    # -- poses and physics ---------------------------------------------------------------
    def place(self, index: int, pose: Pose, lift: float = 0.0) -> None:
        """Teleport object ``index`` to ``pose`` raised by ``lift`` metres, at rest."""
        self._pristine = None
        pb, c = self.pb, self.client
        body = self.bodies[index]
        x, y, z = pose.position
        pb.resetBasePositionAndOrientation(body, (x, y, z + lift), pose.orientation,
                                           physicsClientId=c)
        pb.resetBaseVelocity(body, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=c)

    def poses(self) -> NDArray[np.float64]:
        """Current poses ``(N, 7)`` (position, quaternion xyzw) of the instance's objects."""
        pb, c = self.pb, self.client
        out = np.empty((len(self.bodies), 7), dtype=np.float64)
        for i, body in enumerate(self.bodies):
            pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=c)
            out[i, :3] = pos
            out[i, 3:] = orn
        return out

    def speeds(self) -> tuple[float, float]:
        """Largest linear (m/s) and angular (rad/s) speed over the instance's objects."""
        pb, c = self.pb, self.client
        lin = 0.0
        ang = 0.0
        for body in self.bodies:
            v, w = pb.getBaseVelocity(body, physicsClientId=c)
            lin = max(lin, v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
            ang = max(ang, w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        return math.sqrt(lin), math.sqrt(ang)

    def step(self, n: int = 1) -> None:
        """Advance the simulation by ``n`` fixed time steps."""
        self._pristine = None
        pb, c = self.pb, self.client
        for _ in range(n):
            pb.stepSimulation(physicsClientId=c)

    def settle(
        self,
        *,
        max_steps: int = 480,
        linear_tol: float = 2e-3,
        angular_tol: float = 2e-2,
        calm_steps: int = 4,
        min_steps: int = 4,
        floor_z: float | None = None,
    ) -> SettleResult:
        """Step until every object moves slower than the tolerances for ``calm_steps``
        consecutive steps (at least ``min_steps``), or ``max_steps`` pass, or (when
        ``floor_z`` is given) an object's centre drops below ``floor_z``: it has left the
        table and would fall for ever, there is no floor."""
        self._pristine = None
        pb, c = self.pb, self.client
        calm = 0
        lin = ang = 0.0
        for k in range(1, max_steps + 1):
            pb.stepSimulation(physicsClientId=c)
            lin, ang = self.speeds()
            calm = calm + 1 if (lin < linear_tol and ang < angular_tol) else 0
            if calm >= calm_steps and k >= min_steps:
                return SettleResult(k, True, lin, ang)
            if floor_z is not None and k % 8 == 0 and calm == 0:
                lowest = min((pb.getBasePositionAndOrientation(b, physicsClientId=c)[0][2]
                              for b in self.bodies), default=floor_z)
                if lowest < floor_z:
                    return SettleResult(k, False, lin, ang, {"lowest_z": float(lowest)})
        return SettleResult(max_steps, False, lin, ang)

    @contextmanager
    def solver_iterations(self, iterations: int) -> Iterator[None]:
        """Run the block with ``iterations`` solver iterations, then restore the default."""
        pb, c = self.pb, self.client
        pb.setPhysicsEngineParameter(numSolverIterations=iterations, physicsClientId=c)
        try:
            yield
        finally:
            pb.setPhysicsEngineParameter(numSolverIterations=self.config.solver_iterations,
                                         physicsClientId=c)

    def contacts(self, indices: Sequence[int]) -> list[tuple[int, int, float]]:
        """Contacts touching the objects ``indices`` after a collision-detection pass:
        (object index, other object index or -1 for the table/robot, signed distance in
        metres, negative = penetrating), deepest per pair."""
        pb, c = self.pb, self.client
        pb.performCollisionDetection(physicsClientId=c)
        lut = self._seg_lut
        wanted = {self.bodies[i] for i in indices}
        deepest: dict[tuple[int, int], float] = {}
        for pt in pb.getContactPoints(physicsClientId=c):
            a, b, dist = int(pt[1]), int(pt[2]), float(pt[8])
            for body, other in ((a, b), (b, a)):
                if body in wanted:
                    key = (int(lut[body + 1]), int(lut[other + 1]))
                    deepest[key] = min(deepest.get(key, dist), dist)
        return [(i, j, d) for (i, j), d in sorted(deepest.items())]

    # -- rendering ---------------------------------------------------------------------
    def _raw(self, cam: Camera) -> tuple[NDArray[np.uint8], NDArray[np.float32],
                                         NDArray[np.int32]]:
        """One TinyRenderer pass: RGB with the background colour where no body is seen,
        metric depth, and PyBullet body ids (-1 where no body)."""
        rgb, zbuf, seg_ids = self._raw_zbuffer(cam)
        return rgb, cam.linearize_depth(zbuf), seg_ids

    def _raw_zbuffer(self, cam: Camera, client: int | None = None
                     ) -> tuple[NDArray[np.uint8], NDArray[Any], NDArray[np.int32]]:
        """:meth:`_raw` with the z-buffer as TinyRenderer gives it, in [0, 1] (in
        ``client``, by default the world's)."""
        pb, cv2 = self.pb, self._cv2
        c = self.client if client is None else client
        view, projection = _gl_matrices(cam)
        _, _, rgba, zbuf, seg = pb.getCameraImage(
            cam.width,
            cam.height,
            viewMatrix=view,
            projectionMatrix=projection,
            shadow=int(self.config.shadow),
            lightDirection=list(self.config.light_direction),
            lightColor=[1.0, 1.0, 1.0],
            lightDistance=2.0,
            lightAmbientCoeff=0.55,
            lightDiffuseCoeff=0.5,
            lightSpecularCoeff=0.05,
            renderer=pb.ER_TINY_RENDERER,
            physicsClientId=c,
        )
        rgba = np.asarray(rgba, dtype=np.uint8).reshape(cam.height, cam.width, 4)
        seg_ids = np.asarray(seg, dtype=np.int32).reshape(cam.height, cam.width)
        rgb = cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB)  # 30x faster than rgba[..., :3].copy()
        cv2.copyTo(self._fill(cam.height, cam.width), (seg_ids < 0).view(np.uint8), rgb)
        return rgb, np.asarray(zbuf).reshape(cam.height, cam.width), seg_ids

    def render(self, camera: Camera | None = None, *, composite: bool = False,
               out: RenderedImages | None = None) -> RenderedImages:
        """Render RGB, metric depth and object-index segmentation with TinyRenderer.

        ``out`` (arrays of the camera's shape and the images' dtypes, e.g. one state's
        slices of an episode's arrays) receives the images and is returned: a composite
        render is then assembled in place, without an intermediate copy of the
        background (the same values).

        ``composite=True`` renders only the objects, with the table and the robot hidden,
        over a cached image of the empty scene (see :meth:`prepare_background`, which must
        have run for this camera since the robot last moved). The table fills most of the
        picture and costs ~2/3 of a full render; the composite equals the full render
        except for the odd pixel where an object's bottom edge and the table top are at
        the same depth (measured: 2 of 34,000 object pixels over 10 scenes at 320x240).
        """
        cam = self.camera if camera is None else camera
        if out is not None:
            _check_out(out, cam)
        if not composite:
            self._require_scenery_visuals("a full render (composite=False)")
            rgb, depth, seg_ids = self._raw(cam)
            full = RenderedImages(rgb, depth, np.take(self._seg_lut, seg_ids + 1))
            if out is None:
                return full
            np.copyto(out.rgb, full.rgb)
            np.copyto(out.depth, full.depth)
            np.copyto(out.segmentation, full.segmentation)
            return out
        background = self._scenery_cache.get(cam)
        if background is None:
            msg = (f"no cached background for a {cam.width}x{cam.height} camera; call "
                   "World.prepare_background(camera) right after World.begin(), while the "
                   "objects are parked and the robot is at rest")
            raise InvalidArgument(msg)
        lut = self._seg_lut
        if self._twin_draws:
            twin = self._twin
            assert twin is not None
            twin.follow(self.client, self.bodies)
            rgb_o, zbuf_o, seg_o = self._raw_zbuffer(cam, twin.client)
            lut = twin.lut
        else:
            with self._hidden(self._scenery):
                rgb_o, zbuf_o, seg_o = self._raw_zbuffer(cam)
        cv2 = self._cv2
        seen = seg_o >= 0
        if out is None:
            out = RenderedImages(background.rgb.copy(), background.depth.copy(),
                                 background.segmentation.copy())  # all -1 (= lut[0])
        else:
            np.copyto(out.rgb, background.rgb)
            np.copyto(out.depth, background.depth)
            np.copyto(out.segmentation, background.segmentation)
        cv2.copyTo(rgb_o, seen.view(np.uint8), out.rgb)
        # only the objects' pixels are kept: only they are made metric (pixel by pixel,
        # so the same values)
        out.depth[seen] = cam.linearize_depth(zbuf_o[seen])
        out.segmentation[seen] = lut[seg_o[seen] + 1]
        return out

    def prepare_background(self, camera: Camera | None = None) -> None:
        """Cache the empty scene (table, robot at rest, no objects) for ``camera``.

        Call it right after :meth:`begin` (objects parked out of view, the Panda just
        reset to its rest pose), so that the cached pixels are the same in every process.
        Cheap when the camera is already cached."""
        cam = self.camera if camera is None else camera
        if cam in self._scenery_cache:
            return
        self._require_scenery_visuals("prepare_background()")
        if any(self.pb.getBasePositionAndOrientation(b, physicsClientId=self.client)[0][2]
               > _PARK_ORIGIN[2] + 1.0 for b in self.bodies):
            msg = ("prepare_background() must run before any object is placed; call it "
                   "right after World.begin()")
            raise InvalidArgument(msg)
        rgb, depth, seg_ids = self._raw(cam)
        self._scenery_cache[cam] = RenderedImages(rgb, depth, np.full_like(seg_ids, -1,
                                                                             dtype=np.int16))

    def has_background(self, camera: Camera | None = None) -> bool:
        """Whether the empty scene is cached for ``camera`` (see :meth:`prepare_background`),
        so that composite renders need no scenery visuals."""
        return (self.camera if camera is None else camera) in self._scenery_cache

    def _require_scenery_visuals(self, what: str) -> None:
        if not self._scenery_visuals:
            msg = (f"{what} needs the table and the Panda visible, but this instance was "
                   "begun with World.begin(objects, scenery_visuals=False); begin it with "
                   "scenery_visuals=True (the default)")
            raise InvalidArgument(msg)

    @contextmanager
    def _hidden(self, shapes: Sequence[tuple[int, int, tuple[float, ...]]]) -> Iterator[None]:
        """Make visual shapes (body, link, rgba) transparent, which TinyRenderer skips."""
        pb, c = self.pb, self.client
        for body, link, rgba in shapes:
            pb.changeVisualShape(body, link, rgbaColor=[*rgba[:3], 0.0], physicsClientId=c)
        try:
            yield
        finally:
            for body, link, rgba in shapes:
                pb.changeVisualShape(body, link, rgbaColor=list(rgba), physicsClientId=c)

    def _fill(self, height: int, width: int) -> NDArray[np.uint8]:
        key = (height, width)
        img = self._fills.get(key)
        if img is None:
            img = np.empty((height, width, 3), dtype=np.uint8)
            img[:] = self.config.background
            self._fills[key] = img
        return img

    # -- bookkeeping ---------------------------------------------------------------------
    def body_count(self) -> int:
        """Number of bodies in the client: the scenery and the current instance's objects."""
        n: int = self.pb.getNumBodies(physicsClientId=self.client)
        return n

    def close(self) -> None:
        """Disconnect the client (idempotent)."""
        if not self._closed:
            self.pb.disconnect(physicsClientId=self._full_client)
            if self._lean_client is not None:
                self.pb.disconnect(physicsClientId=self._lean_client)
            if self._twin is not None:
                self._twin.close()
            self._closed = True

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
