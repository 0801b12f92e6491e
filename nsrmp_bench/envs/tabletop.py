"""``nsrmp_bench/Tabletop-v0``: one instance of a split part, run in closed loop.

Example::

    import gymnasium as gym
    import nsrmp_bench.envs  # registers the ids (see nsrmp_bench.envs)

    env = gym.make("nsrmp_bench/Tabletop-v0", data="data/smoke", part="test", boxes="gold")
    obs, info = env.reset(seed=0, options={"instance": "smoke-v2-test-000003"})
    obs, reward, terminated, truncated, info = env.step(
        {"pick": [120.0, 140.0], "place": [200.0, 150.0], "done": 0})
    obs, reward, terminated, truncated, info = env.step({"done": 1})
    info["is_success"]

The instance comes from a generated part on disk (``data``, a part directory or a split
root with ``part``) or is generated on the fly from a split spec (``split``, an id or a
spec file, with ``part``). ``reset(options={"instance": id})`` starts that instance (its
id, or its position in the part as an int); ``reset(seed=s)`` alone draws one with the
environment's random generator.

**Observation** (a dict): ``rgb`` ``(H, W, 3)`` uint8, ``depth`` ``(H, W)`` float32
metres, ``instruction`` (text), ``camera`` (``intrinsics`` 3x3, ``extrinsics`` 4x4
world-to-camera); with ``boxes="gold"`` also ``boxes`` ``(15, 4)`` float32 (the current
amodal boxes, pixel xyxy, scene order, zero rows past the last object) and
``object_mask`` ``(15,)`` (1 for a real object); with ``boxes="classical"`` or
``boxes="learned"`` a detector (``classical-v1``, or ``detector-v1``'s shipped checkpoint)
runs on the current RGB-D at every observation: ``boxes`` are its detections in score
order (not scene order), ``object_mask`` marks them, and ``box_scores`` ``(15,)`` holds
their confidences (only a detector's observation space has it). See
:mod:`nsrmp_bench.envs.observed_boxes`.

**Action** (the action space): ``{"pick": (u, v), "place": (u, v), "done": 0 or 1}`` in
pixels, the convention of Ravens and CLIPort: the object seen at the pick point is moved
so that its centre appears at the place point, on the table or on the object found there.
``done: 1`` ends the episode (nothing is moved). Also accepted, outside the space, for
program policies: ``{"step": (action, subject, reference)}`` with ``action`` one of
``top``/``left``/``right`` (or its index) and object indices in scene order, or a
:class:`~nsrmp_bench.dsl.program.GroundedStep`: the subject goes to the step's target on
the current physical state. A pick point on no object, or a place point whose ray meets
no support, moves nothing (``info["failure"]`` says why).

**End-effector control** (``control="ee"``; ``"pick_place"`` is the default): the action
is ``{"ee": (dx, dy, dz, dyaw), "gripper": 0..1, "done": 0}``, a change of the Panda's
grasp-target pose (m, rad; clipped to 5 cm per axis and 0.5 rad) and a finger opening
(1 open, 0 closed) over one 0.1 s control step, through the robot executor's inverse
kinematics (:mod:`nsrmp_bench.generators.robot.ee_control`); the observation adds
``proprio`` (12 float32) and is rendered with the arm in view; the episode is truncated
after :data:`EE_STEPS_PER_MOVE` control steps per allowed move, and the settled scene is
scored as in the default mode. The executor is then always the Panda.

**Executors**: ``teleport`` (the object is put at its target and physics settles, as in
generation) or ``robot`` (the Panda picks and places it; slower).

**Episode end**: terminated when the policy says done; truncated after the instruction's
step count plus ``step_margin`` (default 2) moves. The reward is 0 except on the last
step, where it is ``info["is_success"]`` as 1.0 or 0.0.

**info**: ``is_success`` (the scorer's success: every object the gold program moves has
final-box IoU >= 0.5 with gold), ``iou_m`` (mean IoU of those objects now), ``boxes``
(``(N, 4)`` current amodal boxes), ``step`` (moves made), ``instance`` (the id),
``max_steps``, ``moved`` (the object moved by the last action, or None) and ``failure``.
"""

from __future__ import annotations

import string
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from nsrmp_bench.dsl.actions import step_problem, target_pose
from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.envs.observed_boxes import (
    BOXES,
    DETECTOR_BOXES,
    Detector,
    check_boxes,
    detected_rows,
    make_detector,
    space_entries,
)
from nsrmp_bench.envs.placing import check_point, picked_object, place_target
from nsrmp_bench.episode import Episode
from nsrmp_bench.episode_views import episode_boxes, episode_camera
from nsrmp_bench.errors import InvalidAction, InvalidArgument, ResetNeeded, UnknownId
from nsrmp_bench.geometry.boxes import box_centres, box_iou
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.instruction_check import MAX_INSTRUCTION_CHARS, check_instruction
from nsrmp_bench.scene import Pose, State
from nsrmp_bench.scoring.metrics import SUCCESS_IOU
from nsrmp_bench.scoring.submission import Prediction
from nsrmp_bench.vocabulary import ACTIONS, MAX_OBJECTS, TABLE_TOP_Z

if TYPE_CHECKING:
    from nsrmp_bench.storage.reader import EpisodeCollection

__all__ = ["BOXES", "CONTROLS", "EE_STEPS_PER_MOVE", "EXECUTORS", "INSTRUCTION_CHARSET",
           "TabletopEnv"]

EXECUTORS: Final = ("teleport", "robot")
CONTROLS: Final = ("pick_place", "ee")
"""``pick_place``: an action is a whole move (pick and place points, or a DSL step);
``ee``: an end-effector pose change and a gripper command at 10 Hz (the Panda)."""
EE_STEPS_PER_MOVE: Final = 80
"""With ``control="ee"`` the episode is truncated after this many control steps per move
allowed (the instruction's steps plus the margin)."""
INSTRUCTION_CHARSET: Final = frozenset(string.printable)
MAX_INSTRUCTION: Final = MAX_INSTRUCTION_CHARS
_FLOOR_Z: Final = TABLE_TOP_Z - 0.105  # an object below this has left the table
F64 = NDArray[np.float64]
Action = Mapping[str, Any] | GroundedStep


def _pose_state(poses: NDArray[np.float64]) -> State:
    return tuple(
        Pose((float(p[0]), float(p[1]), float(p[2])),
             (float(p[3]), float(p[4]), float(p[5]), float(p[6])))
        for p in poses
    )


class _Source:
    """Where the instances come from: a part on disk or a split spec."""

    def __init__(self, data: str | Path | None, split: str | None, part: str) -> None:
        self.collection: EpisodeCollection | None = None
        self.spec: Any = None
        self.part = part
        if data is not None:
            from nsrmp_bench.storage import open as open_storage

            self.collection = open_storage(Path(data), part=part)
            self.ids: list[str] = list(self.collection.ids)
        elif split is not None:
            from nsrmp_bench.split_specs import resolve_split

            self.spec = resolve_split(split)
            count = self.spec.part(part).count
            self.ids = [self.spec.episode_id(part, i) for i in range(count)]
        else:
            msg = ("TabletopEnv needs data= (a generated part or split directory) or split= "
                   "(a split id such as 'smoke-v2', generated on the fly); got neither")
            raise InvalidArgument(msg)
        if not self.ids:
            msg = f"{data or split} part {part!r} holds no instance; generate it first"
            raise InvalidArgument(msg)
        self._position = {e: i for i, e in enumerate(self.ids)}

    def index(self, instance: str | int) -> int:
        if isinstance(instance, (int, np.integer)) and not isinstance(instance, bool):
            if 0 <= int(instance) < len(self.ids):
                return int(instance)
            msg = (f"instance {int(instance)} is out of range: this part has instances "
                   f"0..{len(self.ids) - 1}; pass an index in range or an id such as "
                   f"{self.ids[0]!r}")
            raise UnknownId(msg)
        if isinstance(instance, str) and instance in self._position:
            return self._position[instance]
        msg = (f"unknown instance {instance!r}: this part's ids run from {self.ids[0]!r} to "
               f"{self.ids[-1]!r} ({len(self.ids)} instances); pass one of them or its index")
        raise UnknownId(msg)

    def camera(self) -> Camera | None:
        if self.spec is not None:
            from nsrmp_bench.geometry.default_camera import official_camera

            cam: Camera = official_camera(*self.spec.image)
            return cam
        return None

    def episode(self, index: int, world: Any) -> Episode:
        if self.collection is not None:
            ep: Episode = self.collection.episode(index, images=False)
            return ep
        from nsrmp_bench.generators.generate import make_episode

        made: Episode = make_episode(self.spec, self.part, index, world)
        return made


class TabletopEnv(gym.Env[dict[str, Any], dict[str, Any]]):
    """The closed-loop tabletop environment (see the module docstring)."""

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 2}  # noqa: RUF012

    def __init__(
        self,
        data: str | Path | None = None,
        *,
        split: str | None = None,
        part: str = "test",
        boxes: str | None = None,
        executor: str = "teleport",
        step_margin: int = 2,
        profile: str = "fast",
        render_mode: str | None = None,
        control: str = "pick_place",
    ) -> None:
        boxes = check_boxes(boxes)
        if control not in CONTROLS:
            msg = (f"control={control!r} is not one of {list(CONTROLS)}; use 'pick_place' "
                   "(whole moves) or 'ee' (end-effector pose changes and a gripper command)")
            raise InvalidArgument(msg)
        if executor not in EXECUTORS:
            msg = (f"executor={executor!r} is not one of {list(EXECUTORS)}; use 'teleport' "
                   "(place and settle) or 'robot' (the Panda picks and places)")
            raise InvalidArgument(msg)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            msg = f"render_mode={render_mode!r} is not supported; use None or 'rgb_array'"
            raise InvalidArgument(msg)
        if step_margin < 0:
            msg = f"step_margin must be >= 0, got {step_margin}"
            raise InvalidArgument(msg)
        self.source = _Source(data, split, part)
        self.boxes_mode = boxes
        self._detector: Detector | None = (make_detector(boxes) if boxes in DETECTOR_BOXES
                                           else None)
        self.control = control
        self.executor = "robot" if control == "ee" else executor  # ee: the Panda moves
        self.step_margin = int(step_margin)
        self.profile = profile
        self.render_mode = render_mode
        self._world: Any = None
        first_camera = self.source.camera()
        if first_camera is None:
            first_camera = episode_camera(self.source.episode(0, None))
        self.camera: Camera = first_camera
        self.observation_space = self._observation_space(self.camera)
        w, h = float(self.camera.width), float(self.camera.height)
        point = spaces.Box(low=np.zeros(2, np.float32), high=np.array([w, h], np.float32),
                           dtype=np.float32)
        if control == "ee":
            from nsrmp_bench.generators.robot.ee_control import MAX_TRANSLATION, MAX_YAW

            lim = np.array([MAX_TRANSLATION] * 3 + [MAX_YAW], np.float32)
            self.action_space = spaces.Dict({
                "ee": spaces.Box(-lim, lim, dtype=np.float32),
                "gripper": spaces.Box(0.0, 1.0, (), np.float32),
                "done": spaces.Discrete(2)})
        else:
            self.action_space = spaces.Dict({"pick": point, "place": point,
                                             "done": spaces.Discrete(2)})
        self._ee: Any = None
        self._control_steps = 0
        self.episode: Episode | None = None
        self._instruction = ""
        self._ended = True
        self._images: Any = None
        self._poses: F64 = np.zeros((0, 7))
        self._gold_final: F64 = np.zeros((0, 4))
        self._moved_gold: tuple[int, ...] = ()
        self._history: list[dict[str, Any]] = []
        self._state_boxes: list[F64] = []
        self._t = 0.0

    # -- spaces --------------------------------------------------------------------------
    def _observation_space(self, cam: Camera) -> spaces.Dict:
        h, w = cam.height, cam.width
        inf = np.inf
        entries: dict[str, spaces.Space[Any]] = {
            "rgb": spaces.Box(0, 255, (h, w, 3), np.uint8),
            "depth": spaces.Box(0.0, inf, (h, w), np.float32),
            "instruction": spaces.Text(MAX_INSTRUCTION, min_length=1,
                                       charset="".join(sorted(INSTRUCTION_CHARSET))),
            "camera": spaces.Dict({
                "intrinsics": spaces.Box(-inf, inf, (3, 3), np.float64),
                "extrinsics": spaces.Box(-inf, inf, (4, 4), np.float64),
            }),
        }
        entries.update(space_entries(self.boxes_mode, w, h, MAX_OBJECTS))
        if self.control == "ee":
            from nsrmp_bench.generators.robot.ee_control import PROPRIO_SIZE

            entries["proprio"] = spaces.Box(-inf, inf, (PROPRIO_SIZE,), np.float32)
        return spaces.Dict(entries)

    # -- the world -----------------------------------------------------------------------
    def _world_for(self, cam: Camera) -> Any:
        if self._world is None or self._world.camera != cam:
            from nsrmp_bench.generators.world.world import World

            if self._world is not None:
                self._world.close()
            self._world = World(cam)
        return self._world

    def _stage(self, episode: Episode) -> None:
        """Put the instance's initial scene in the world as generation does, and settle."""
        from nsrmp_bench.generators.world.realise import Tolerances

        world = self._world
        sym = episode.symbolic
        tol = Tolerances()
        world.begin(sym.scene.objects)
        world.prepare_background(self.camera)
        with world.solver_iterations(world.config.settle_solver_iterations):
            for i, pose in enumerate(sym.states[0]):
                world.place(i, pose, lift=tol.lift)
            world.settle(max_steps=tol.settle_max_steps, floor_z=_FLOOR_Z)

    def _measure(self) -> None:
        world = self._world
        # the arm is in view under end-effector control (a full render); else hidden
        self._images = world.render(self.camera, composite=self.control != "ee")
        self._poses = np.asarray(world.poses(), dtype=np.float64)
        self._state_boxes.append(self._boxes_now())

    def _boxes_now(self) -> F64:
        assert self.episode is not None
        objects = self.episode.symbolic.scene.objects
        ext = np.array([o.extents for o in objects], dtype=np.float64).reshape(-1, 3)
        out: F64 = self.camera.amodal_boxes(ext, self._poses[:, :3],
                                            self._poses[:, 3:7]).astype(np.float64)
        return out

    # -- gymnasium API ---------------------------------------------------------------------
    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an instance: ``options["instance"]`` (id or index), else one drawn by seed;
        ``options["instruction"]`` replaces the instance's instruction in the observations
        (what a person says instead; checked like every instruction, printable ASCII)."""
        super().reset(seed=seed)
        if self._ee is not None:  # before the world is reset or replaced
            self._ee.stop()
            self._ee = None
        opts = dict(options or {})
        unknown = set(opts) - {"instance", "instruction"}
        if unknown:
            msg = (f"unknown reset option(s) {sorted(unknown)}; the options are 'instance' "
                   "and 'instruction'")
            raise InvalidArgument(msg)
        said = opts.get("instruction")
        if said is not None or "instruction" in opts:
            said = check_instruction(said, "reset option 'instruction'")
            odd = sorted(set(said) - INSTRUCTION_CHARSET)
            if odd:
                msg = (f"reset option 'instruction' holds {odd[:5]}; expected printable "
                       "ASCII (the observation space's charset): write it without them")
                raise InvalidArgument(msg)
        if opts.get("instance") is not None:
            index = self.source.index(opts["instance"])
        else:
            index = int(self.np_random.integers(len(self.source.ids)))
        spec_camera = self.source.camera()
        if spec_camera is None:  # a part on disk: the episode says its camera
            episode = self.source.episode(index, None)
            self._world_for(episode_camera(episode))
        else:  # generated here, in the world of the spec's camera
            episode = self.source.episode(index, self._world_for(spec_camera))
        self.camera = episode_camera(episode)
        self._world_for(self.camera)
        self.episode = episode
        self._instruction = check_instruction(
            said if said is not None else episode.symbolic.instruction.text,
            f"the instruction of episode {episode.id!r}")
        gold = episode_boxes(episode)
        self._gold_final = gold[-1]
        self._moved_gold = episode.symbolic.moved
        self._history = []
        self._state_boxes = []
        self._t = 0.0
        self._control_steps = 0
        self._stage(episode)
        if self.control == "ee":
            from nsrmp_bench.generators.robot.ee_control import EndEffectorControl

            self._ee = EndEffectorControl(self._world, self.profile)
            self._ee.start()
        self._measure()
        self._ended = False
        return self._observation(), self._info(moved=None, failure=None)

    def step(self, action: Action) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        """Carry out one action (see the module docstring)."""
        if self.episode is None:
            msg = "step() called before reset(); call env.reset() to start an instance"
            raise ResetNeeded(msg)
        if self._ended:
            msg = (f"step() called after the episode of {self.episode.id} ended (terminated "
                   "or truncated); call env.reset() to start the next one")
            raise ResetNeeded(msg)
        if self.control == "ee":
            return self._step_ee(action)
        done, move, failure = self._decode(action)
        moved: int | None = None
        if not done:
            if move is not None:
                subject, target, record = move
                self._execute(subject, target)
                moved = subject
                self._history.append(record)
            else:
                self._history.append({"failure": failure})
            self._measure()
        steps = len(self._history)
        truncated = not done and steps >= self.max_steps
        self._ended = done or truncated
        info = self._info(moved=moved, failure=failure)
        reward = float(info["is_success"]) if self._ended else 0.0
        return self._observation(), reward, done, truncated, info

    def _step_ee(self, action: Action) -> tuple[dict[str, Any], float, bool, bool,
                                                dict[str, Any]]:
        """One end-effector control step (``control="ee"``)."""
        if not isinstance(action, Mapping):
            msg = (f"with control='ee' an action is {{'ee': (dx, dy, dz, dyaw), 'gripper': "
                   f"0..1, 'done': 0}} or {{'done': 1}}; got {type(action).__name__}")
            raise InvalidAction(msg)
        unknown = set(action) - {"ee", "gripper", "done"}
        if unknown:
            msg = (f"unknown action key(s) {sorted(unknown)} with control='ee'; the keys are "
                   "'ee', 'gripper' and 'done' (pick/place and step need control='pick_place')")
            raise InvalidAction(msg)
        try:
            done = bool(int(np.asarray(action.get("done", 0)).reshape(())))
        except (TypeError, ValueError) as exc:
            msg = f"action 'done' must be 0 or 1, got {action.get('done')!r}"
            raise InvalidAction(msg) from exc
        if not done:
            if "ee" not in action:
                msg = (f"an end-effector action needs 'ee' (dx, dy, dz, dyaw); got keys "
                       f"{sorted(action)}; to stop, pass {{'done': 1}}")
                raise InvalidAction(msg)
            try:
                grip = float(np.asarray(action.get("gripper", self._ee.gripper)).reshape(()))
            except (TypeError, ValueError) as exc:
                msg = f"action 'gripper' must be a number in [0, 1], got {action['gripper']!r}"
                raise InvalidAction(msg) from exc
            self._ee.step(action["ee"], grip)
            self._control_steps += 1
        truncated = not done and self._control_steps >= self.max_steps
        self._ended = done or truncated
        if self._ended:  # the scene is scored at rest
            self._world.settle(max_steps=240, floor_z=_FLOOR_Z)
        self._measure()
        info = self._info(moved=None, failure=None)
        reward = float(info["is_success"]) if self._ended else 0.0
        return self._observation(), reward, done, truncated, info

    def render(self) -> NDArray[np.uint8] | None:
        """The current RGB image with ``render_mode="rgb_array"``; None otherwise."""
        if self.render_mode != "rgb_array" or self._images is None:
            return None
        rgb: NDArray[np.uint8] = self._images.rgb.copy()
        return rgb

    def close(self) -> None:
        """Release the PyBullet world."""
        if self._ee is not None:
            self._ee.stop()
            self._ee = None
        if self._world is not None:
            self._world.close()
            self._world = None
        super().close()

    # -- decoding and execution ------------------------------------------------------------
    @property
    def max_steps(self) -> int:
        """Moves after which the episode is truncated: the instruction's steps + margin."""
        assert self.episode is not None
        moves = self.episode.symbolic.num_steps + self.step_margin
        return moves * EE_STEPS_PER_MOVE if self.control == "ee" else moves

    def _decode(self, action: Action) -> tuple[bool, tuple[int, Pose, dict[str, Any]] | None,
                                                str | None]:
        """(done, (subject, target, record) or None, failure)."""
        assert self.episode is not None
        if isinstance(action, GroundedStep):
            return False, *self._decode_step(action)
        if not isinstance(action, Mapping):
            msg = (f"an action must be a dict {{'pick': (u, v), 'place': (u, v), 'done': 0}}, "
                   f"{{'step': (action, subject, reference)}} or {{'done': 1}}; got "
                   f"{type(action).__name__} {action!r}")
            raise InvalidAction(msg)
        unknown = set(action) - {"pick", "place", "done", "step"}
        if unknown:
            msg = (f"unknown action key(s) {sorted(unknown)}; the keys are 'pick', 'place', "
                   "'done' and 'step'")
            raise InvalidAction(msg)
        done = action.get("done", 0)
        try:
            done_flag = bool(int(np.asarray(done).reshape(())))
        except (TypeError, ValueError) as exc:
            msg = f"action 'done' must be 0 or 1, got {done!r}"
            raise InvalidAction(msg) from exc
        if done_flag:
            return True, None, None
        if "step" in action:
            if "pick" in action or "place" in action:
                msg = ("an action gives either 'step' or 'pick' and 'place', not both; got "
                       f"keys {sorted(action)}")
                raise InvalidAction(msg)
            return False, *self._decode_step(action["step"])
        if "pick" not in action or "place" not in action:
            msg = (f"a pick-and-place action needs both 'pick' and 'place' (u, v) points; got "
                   f"keys {sorted(action)}; to stop, pass {{'done': 1}}")
            raise InvalidAction(msg)
        return False, *self._decode_pick_place(action["pick"], action["place"])

    def _decode_step(self, raw: GroundedStep | Iterable[int | str]
                     ) -> tuple[tuple[int, Pose, dict[str, Any]] | None, str | None]:
        assert self.episode is not None
        objects = self.episode.symbolic.scene.objects
        n = len(objects)
        if isinstance(raw, GroundedStep):
            name, subject, reference = raw.action, raw.subject, raw.reference
        else:
            try:
                a, s, r = raw
                name = ACTIONS[int(a)] if not isinstance(a, str) else a
                subject, reference = int(s), int(r)
            except (TypeError, ValueError, IndexError) as exc:
                msg = (f"a step action must be (action, subject, reference) with action one "
                       f"of {list(ACTIONS)} or its index 0..{len(ACTIONS) - 1}; got {raw!r}")
                raise InvalidAction(msg) from exc
        if name not in ACTIONS:
            msg = f"unknown step action {name!r}; expected one of {list(ACTIONS)}"
            raise InvalidAction(msg)
        for role, k in (("subject", subject), ("reference", reference)):
            if not 0 <= k < n:
                msg = (f"the step's {role} is object {k}, but instance {self.episode.id} has "
                       f"objects 0..{n - 1} (scene order); name an object of the scene")
                raise InvalidAction(msg)
        if subject == reference:
            return None, f"the step moves object {subject} relative to itself; nothing moved"
        state = _pose_state(self._poses)
        step = GroundedStep(name, subject, reference)
        target = target_pose(objects, state, name, subject, reference)
        record = {"subject": subject, "step": step, "problem": step_problem(objects, state, step,
                                                        self.episode.symbolic.scene.workspace)}
        return (subject, target, record), None

    def _decode_pick_place(self, pick: Sequence[float] | NDArray[np.float64],
                           place: Sequence[float] | NDArray[np.float64]
                           ) -> tuple[tuple[int, Pose, dict[str, Any]] | None, str | None]:
        assert self.episode is not None
        p0 = check_point(self.camera, pick, "pick")
        p1 = check_point(self.camera, place, "place")
        subject = picked_object(self._images.segmentation, p0)
        if subject is None:
            return None, f"no object at the pick point {p0}; nothing moved"
        objects = self.episode.symbolic.scene.objects
        found = place_target(self.camera, objects, _pose_state(self._poses), subject, p1)
        if found is None:
            return None, f"the place point {p1} meets no support; nothing moved"
        target, support = found
        return (subject, target, {"subject": subject, "pick": p0, "place": p1,
                                  "support": support}), None

    def _execute(self, subject: int, target: Pose) -> None:
        world = self._world
        if self.executor == "robot":
            from nsrmp_bench.generators.robot.pick_and_place import execute_step

            result = execute_step(world, subject, target, self.profile,
                                  step_index=len(self._history), t0=self._t)
            self._t += result.sim_time
            return
        from nsrmp_bench.generators.world.realise import Tolerances

        tol = Tolerances()
        with world.solver_iterations(world.config.settle_solver_iterations):
            world.place(subject, target, lift=tol.lift)
            world.settle(max_steps=tol.settle_max_steps, floor_z=_FLOOR_Z)

    # -- observation, info, predictions -------------------------------------------------------
    def _observation(self) -> dict[str, Any]:
        assert self.episode is not None
        cam = self.camera
        obs: dict[str, Any] = {
            "rgb": self._images.rgb.copy(),
            "depth": np.asarray(self._images.depth, dtype=np.float32).copy(),
            "instruction": self._instruction,
            "camera": {"intrinsics": np.asarray(cam.intrinsics, dtype=np.float64).copy(),
                       "extrinsics": np.asarray(cam.extrinsics, dtype=np.float64).copy()},
        }
        if self.boxes_mode == "gold":
            n = len(self._poses)
            boxes = np.zeros((MAX_OBJECTS, 4), dtype=np.float32)
            boxes[:n] = self._state_boxes[-1]
            mask = np.zeros(MAX_OBJECTS, dtype=np.int8)
            mask[:n] = 1
            obs["boxes"] = boxes
            obs["object_mask"] = mask
        elif self._detector is not None:
            found = self._detector(self._images.rgb, np.asarray(self._images.depth,
                                                                dtype=np.float32), cam)
            obs["boxes"], obs["object_mask"], obs["box_scores"] = detected_rows(
                found, MAX_OBJECTS, cam.width, cam.height)
        if self.control == "ee":
            obs["proprio"] = self._ee.proprio()
        return obs

    def _scores(self) -> tuple[bool, float]:
        boxes = self._state_boxes[-1]
        moved = list(self._moved_gold)
        if not moved:
            return True, float("nan")
        iou = box_iou(boxes[moved], self._gold_final[moved])
        return bool(np.all(iou >= SUCCESS_IOU)), float(np.mean(iou))

    def _info(self, *, moved: int | None, failure: str | None) -> dict[str, Any]:
        assert self.episode is not None
        success, iou_m = self._scores()
        return {
            "is_success": success,
            "iou_m": iou_m,
            "boxes": self._state_boxes[-1].copy(),
            "step": self._control_steps if self.control == "ee" else len(self._history),
            "instance": self.episode.id,
            "max_steps": self.max_steps,
            "moved": moved,
            "failure": failure,
        }

    def object_poses(self) -> F64:
        """The objects' current poses ``(N, 7)`` (position, quaternion xyzw): privileged,
        for scripted policies such as ``oracle-ee``."""
        return self._poses.copy()

    def prediction(self) -> Prediction:
        """The predictions-file line of what has been achieved so far.

        ``boxes`` and ``positions`` are the current ones; ``program`` is given when every
        move was a DSL step; ``step_boxes`` when the moves made equal the instruction's
        step count; ``pick``/``place`` are the centres of the first moved object's box
        before and after its move.
        """
        if self.episode is None:
            msg = "prediction() called before reset(); run an episode first"
            raise ResetNeeded(msg)
        steps = [h.get("step") for h in self._history]
        program = (tuple(s for s in steps if s is not None)
                   if steps and all(s is not None for s in steps) else None)
        n_gold = self.episode.symbolic.num_steps
        step_boxes = (np.stack(self._state_boxes[1:])
                      if len(self._history) == n_gold and n_gold > 0 else None)
        pick = place = None
        first = next((k for k, h in enumerate(self._history) if "failure" not in h), None)
        if first is not None:
            subject = int(self._history[first]["subject"])
            cx, cy = box_centres(self._state_boxes[first][subject])
            px, py = box_centres(self._state_boxes[first + 1][subject])
            pick, place = (float(cx), float(cy)), (float(px), float(py))
        return Prediction(
            id=self.episode.id,
            boxes=self._state_boxes[-1].copy(),
            program=program,
            step_boxes=step_boxes,
            pick=pick,
            place=place,
            positions=self._poses[:, :3].copy(),
        )

