"""Objects, poses, world states and scenes: frozen, typed, JSON round-trippable."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from nsrmp_bench.canonical import content_hash
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.vocabulary import COLOURS, EXTENTS, SHAPES, TARGET_AREA, Area

__all__ = ["Pose", "Quat", "Scene", "SceneObject", "State", "Vec3", "yaw_quaternion"]

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


def yaw_quaternion(yaw: float) -> Quat:
    """The xyzw quaternion of a rotation by ``yaw`` radians about +z."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def _vec(value: Any, n: int, what: str) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError) as exc:
        msg = f"{what} must be a list of {n} numbers, got {value!r}"
        raise InvalidArgument(msg) from exc
    if len(out) != n or not all(math.isfinite(v) for v in out):
        msg = f"{what} must be {n} finite numbers, got {value!r}"
        raise InvalidArgument(msg)
    return out


@dataclass(frozen=True)
class Pose:
    """A rigid pose: position in metres (world frame) and orientation as xyzw quaternion."""

    position: Vec3
    orientation: Quat = (0.0, 0.0, 0.0, 1.0)

    @property
    def yaw(self) -> float:
        """Rotation about +z in radians (exact for yaw-only orientations)."""
        x, y, z, w = self.orientation
        return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form."""
        return {"position": list(self.position), "orientation": list(self.orientation)}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Pose:
        """Inverse of :meth:`to_dict`."""
        pos = _vec(data.get("position"), 3, "pose.position")
        orn = _vec(data.get("orientation"), 4, "pose.orientation")
        return cls((pos[0], pos[1], pos[2]), (orn[0], orn[1], orn[2], orn[3]))


State = tuple[Pose, ...]
"""The world state: one pose per object, in scene order."""


@dataclass(frozen=True)
class SceneObject:
    """One object of a scene: its shape and colour, fixed for the episode."""

    shape: str
    colour: str

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            msg = f"unknown shape {self.shape!r}; expected one of {', '.join(SHAPES)}"
            raise InvalidArgument(msg)
        if self.colour not in COLOURS:
            msg = f"unknown colour {self.colour!r}; expected one of {', '.join(COLOURS)}"
            raise InvalidArgument(msg)

    @property
    def extents(self) -> Vec3:
        """Full (x, y, z) extents of the object's box in its own frame."""
        return EXTENTS[self.shape]

    @property
    def label(self) -> str:
        """Human label, e.g. ``red cube``."""
        return f"{self.colour} {self.shape}"

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form."""
        return {"shape": self.shape, "colour": self.colour}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SceneObject:
        """Inverse of :meth:`to_dict`."""
        return cls(str(data.get("shape")), str(data.get("colour")))


@dataclass(frozen=True)
class Scene:
    """The objects on the table and their initial poses (same order), and the workspace a
    moved object's centre must stay in (ours, :data:`~nsrmp_bench.vocabulary.TARGET_AREA`,
    unless the scene was made elsewhere, e.g. imported from the original NSRM)."""

    objects: tuple[SceneObject, ...]
    initial: State
    workspace: Area = TARGET_AREA

    def __post_init__(self) -> None:
        if len(self.objects) != len(self.initial):
            msg = (
                f"a scene needs one initial pose per object: got {len(self.objects)} objects "
                f"and {len(self.initial)} poses"
            )
            raise InvalidArgument(msg)

    def __len__(self) -> int:
        return len(self.objects)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form (``workspace`` only when it is not ours)."""
        out: dict[str, Any] = {
            "objects": [
                {**o.to_dict(), **p.to_dict()}
                for o, p in zip(self.objects, self.initial, strict=True)
            ]
        }
        if self.workspace != TARGET_AREA:
            out["workspace"] = self.workspace.to_dict()
        return out

    def at(self, state: State) -> Scene:
        """The same objects and workspace with ``state`` as the initial poses."""
        return Scene(self.objects, state, self.workspace)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Scene:
        """Inverse of :meth:`to_dict`."""
        items = data.get("objects")
        if not isinstance(items, list):
            msg = f"scene.objects must be a list, got {type(items).__name__}"
            raise InvalidArgument(msg)
        objects = tuple(SceneObject.from_dict(d) for d in items)
        poses = tuple(Pose.from_dict(d) for d in items)
        return cls(objects, poses, _workspace(data.get("workspace")))

    @property
    def content_hash(self) -> str:
        """sha256 of the canonical JSON."""
        return content_hash(self.to_dict())


def state_to_list(state: State) -> list[dict[str, Any]]:
    """JSON-able form of a state."""
    return [p.to_dict() for p in state]


def state_from_list(data: object) -> State:
    """Inverse of :func:`state_to_list`."""
    if not isinstance(data, list):
        msg = f"a state must be a list of poses, got {type(data).__name__}"
        raise InvalidArgument(msg)
    return tuple(Pose.from_dict(d) for d in data)


def _workspace(data: Any) -> Area:
    """A scene's stored workspace (ours when absent)."""
    if data is None:
        return TARGET_AREA
    try:
        (x0, x1), (y0, y1) = data["x"], data["y"]
        area = Area(str(data["name"]), float(x0), float(x1), float(y0), float(y1))
    except (KeyError, TypeError, ValueError) as exc:
        msg = (f"scene.workspace must be {{'name', 'x': [min, max], 'y': [min, max]}} in "
               f"metres, got {data!r:.80}")
        raise InvalidArgument(msg) from exc
    if not (area.x_min < area.x_max and area.y_min < area.y_max):
        msg = f"scene.workspace {data!r:.80} is empty; each [min, max] needs min < max"
        raise InvalidArgument(msg)
    return area
