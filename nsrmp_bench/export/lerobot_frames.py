"""The frames of one episode in the LeRobot export, and the features that describe them.

Two kinds of split, told apart by whether their episodes hold a robot trajectory:

**Teleport** (``fps`` 1): one frame per rendered state. ``observation.state`` is every
object's pose (position xyz + quaternion xyzw, scene order, zero rows past the last
object, 15 x 7), ``action`` the move made from that state as image points (pick u, v =
the moved object's box centre before, place u, v = after; zeros on the last frame),
``action.step`` the DSL step (action index, subject, reference; -1 on the last frame).

**Robot** (``fps`` 30, the Panda's recording rate): one frame per recorded sample of the
trajectory, then one closing frame on the final state. ``observation.state`` is the
Panda's joint positions (7 arm joints in radians, 2 finger joints in metres; named in
``info.json``) as stored, ``action`` the joint positions of the next sample (the
position-controlled arm's next target; the closing frame repeats the last sample),
``observation.environment_state`` the object poses of the state the sample's step
started from (15 x 7 as above; the final state on the closing frame),
``observation.sample_time`` the sample's recorded time in seconds (``timestamp`` is the
frame index / 30, the uniform clock lerobot checks; a multi-step episode's samples drift
from it by at most a physics step at each step boundary), ``action.move`` the pick and
place image points of the step being executed and ``action.step`` its DSL step (zeros and
-1 on the closing frame). The camera image of a frame is the render of the state its
step started from (the final state on the closing frame): states are rendered once per
step, not at 30 Hz.

Both: the RGB image is ``observation.images.rgb``; ``next.done`` is true on the last frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.episode import Episode, Trajectory
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.geometry.boxes import box_centres
from nsrmp_bench.vocabulary import ACTIONS, MAX_OBJECTS

__all__ = ["FPS", "IMAGE_KEY", "Frames", "episode_frames", "lerobot_features", "split_kind"]

IMAGE_KEY: Final = "observation.images.rgb"
FPS: Final = {"teleport": 1, "robot": 30}
"""Frames per second of each kind of split."""
_POSE = ("x", "y", "z", "qx", "qy", "qz", "qw")
_POSES = [f"object{i}.{c}" for i in range(MAX_OBJECTS) for c in _POSE]


@dataclass(frozen=True)
class Frames:
    """One episode's frames: its rendered images, which one each frame shows, and a
    column per feature (frame-major)."""

    images: NDArray[np.uint8]  # (S+1, H, W, 3), one per rendered state
    image_of: NDArray[np.int64]  # (F,) the image each frame shows
    columns: dict[str, NDArray[Any]]  # feature name -> (F, ...) values

    def __len__(self) -> int:
        return int(self.image_of.shape[0])


def split_kind(episode: Episode) -> str:
    """``"robot"`` when the episode holds a robot trajectory, else ``"teleport"``."""
    r = episode.rendering
    return "robot" if r is not None and r.trajectory is not None else "teleport"


def _vector(dtype: str, names: list[str]) -> dict[str, Any]:
    return {"dtype": dtype, "shape": [len(names)], "names": names}


def lerobot_features(kind: str, height: int, width: int,
                     joint_names: tuple[str, ...] = ()) -> dict[str, dict[str, Any]]:
    """The ``features`` block of ``info.json`` for a ``kind`` split (see the module)."""
    image = {IMAGE_KEY: {"dtype": "image", "shape": [height, width, 3],
                         "names": ["height", "width", "channels"]}}
    move = _vector("float32", ["pick_u", "pick_v", "place_u", "place_v"])
    step = _vector("int64", ["action", "subject", "reference"])
    if kind == "teleport":
        own = {"observation.state": _vector("float32", _POSES), "action": move,
               "action.step": step}
    elif kind == "robot":
        joints = list(joint_names)
        own = {"observation.state": _vector("float32", joints),
               "observation.environment_state": _vector("float32", _POSES),
               "observation.sample_time": {"dtype": "float32", "shape": [1], "names": None},
               "action": _vector("float32", joints), "action.move": move,
               "action.step": step}
    else:
        msg = f"unknown kind {kind!r}; expected 'teleport' or 'robot'"
        raise InvalidArgument(msg)
    scalar = {"dtype": "int64", "shape": [1], "names": None}
    return {**image, **own,
            "next.done": {"dtype": "bool", "shape": [1], "names": None},
            "timestamp": {"dtype": "float32", "shape": [1], "names": None},
            "frame_index": scalar, "episode_index": scalar, "index": scalar,
            "task_index": scalar}


def _moves(episode: Episode, states: int) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
    """Per state: the move made from it (pick, place image points) and its DSL step."""
    assert episode.rendering is not None
    boxes = np.asarray(episode.rendering.targets.boxes_amodal, dtype=np.float64)
    move = np.zeros((states, 4), dtype=np.float32)
    step = np.full((states, 3), -1, dtype=np.int64)
    for k, g in enumerate(episode.symbolic.grounded):
        move[k, :2] = box_centres(boxes[k, g.subject])
        move[k, 2:] = box_centres(boxes[k + 1, g.subject])
        step[k] = (ACTIONS.index(g.action), g.subject, g.reference)
    return move, step


def _poses(episode: Episode) -> NDArray[np.float32]:
    """(S+1, 105) object poses per state, zero rows past the last object."""
    assert episode.rendering is not None
    poses = np.asarray(episode.rendering.targets.poses, dtype=np.float32)  # (S+1, N, 7)
    states, n = poses.shape[:2]
    out = np.zeros((states, MAX_OBJECTS * 7), dtype=np.float32)
    out[:, : n * 7] = poses.reshape(states, n * 7)
    return out


def _robot(episode: Episode, rgb: NDArray[np.uint8], traj: Trajectory) -> Frames:
    joints = np.asarray(traj.joint_positions, dtype=np.float32)  # (T, J)
    samples = joints.shape[0]
    states = rgb.shape[0]
    of = np.asarray(traj.step, dtype=np.int64)  # (T,) the step each sample belongs to
    if samples == 0 or of.min() < 0 or of.max() >= states - 1:
        msg = (f"episode {episode.id}: its trajectory's step indices run "
               f"{of.min() if samples else None}..{of.max() if samples else None} but it has "
               f"{states - 1} step(s); the file is damaged, regenerate it")
        raise InvalidArgument(msg)
    state_of = np.append(of, states - 1)  # the closing frame shows the final state
    move, step = _moves(episode, states)
    time = np.asarray(traj.time, dtype=np.float64)
    period = 1.0 / FPS["robot"]
    return Frames(images=rgb, image_of=state_of, columns={
        "observation.state": np.concatenate([joints, joints[-1:]]),
        "observation.environment_state": _poses(episode)[state_of],
        "observation.sample_time": np.append(time, time[-1] + period).astype(np.float32),
        "action": np.concatenate([joints[1:], joints[-1:], joints[-1:]]),
        "action.move": move[state_of],
        "action.step": step[state_of],
    })


def episode_frames(episode: Episode, kind: str) -> Frames:
    """The frames of ``episode`` in a ``kind`` split (see the module docstring)."""
    rendering = episode.rendering
    if rendering is None or rendering.observations is None:
        msg = (f"episode {episode.id} has no rendered images; export-lerobot needs a "
               "rendered split")
        raise InvalidArgument(msg)
    if split_kind(episode) != kind:
        msg = (f"episode {episode.id} is a {split_kind(episode)} episode in a split whose "
               f"first episode is a {kind} one; export one executor's split at a time")
        raise InvalidArgument(msg)
    rgb = np.asarray(rendering.observations.rgb)
    if kind == "robot":
        assert rendering.trajectory is not None
        frames = _robot(episode, rgb, rendering.trajectory)
    else:
        move, step = _moves(episode, rgb.shape[0])
        frames = Frames(images=rgb, image_of=np.arange(rgb.shape[0], dtype=np.int64),
                        columns={"observation.state": _poses(episode), "action": move,
                                 "action.step": step})
    done = np.zeros(len(frames), dtype=bool)
    done[-1] = True
    frames.columns["next.done"] = done
    return frames
