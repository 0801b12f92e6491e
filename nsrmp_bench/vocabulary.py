"""The closed vocabulary of the world: shapes, colours, actions, relations, and sizes.

Everything here is data shared by the symbolic executor, the PyBullet world and the
scorer. Units are metres; the world frame has +x to image-right, +y away from the camera
("behind") and +z up. The table top is the plane ``z = TABLE_TOP_Z``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

__all__ = [
    "ABSTAIN_VALUES",
    "ACTIONS",
    "COLOURS",
    "COLOUR_RGBA",
    "EXTENTS",
    "EXTREME_MARGIN",
    "MAX_OBJECTS",
    "MAX_STEPS",
    "MIN_OBJECTS",
    "ORDINALS",
    "PHENOMENA",
    "PHRASINGS",
    "PLACEMENT_MARGIN",
    "RELATIONS",
    "RELATION_AXES",
    "RELATION_THRESHOLD",
    "SAMPLING_AREA",
    "SHAPES",
    "TABLE_TOP_Z",
    "TARGET_AREA",
    "Area",
    "vocabulary_dict",
]

SHAPES: Final = ("cube", "dice", "lego")
COLOURS: Final = ("blue", "green", "red", "cyan", "yellow", "magenta", "white")
ACTIONS: Final = ("top", "left", "right")
RELATIONS: Final = ("left", "right", "behind", "front")
PHRASINGS: Final = ("simple", "complex", "compound")

COLOUR_RGBA: Final[dict[str, tuple[float, float, float, float]]] = {
    "blue": (0.05, 0.15, 0.95, 1.0),
    "green": (0.05, 0.80, 0.15, 1.0),
    "red": (0.90, 0.08, 0.08, 1.0),
    "cyan": (0.10, 0.85, 0.90, 1.0),
    "yellow": (0.95, 0.88, 0.05, 1.0),
    "magenta": (0.85, 0.10, 0.85, 1.0),
    "white": (0.95, 0.95, 0.95, 1.0),
}

# Full extents (x, y, z) of each shape's axis-aligned box in its own frame, in metres.
# The lego brick is 2x2 studs: a 64 mm square body 38 mm tall plus 8 mm studs; its box
# includes the studs, which is what an object placed on it rests on.
EXTENTS: Final[dict[str, tuple[float, float, float]]] = {
    "cube": (0.05, 0.05, 0.05),
    "dice": (0.05, 0.05, 0.05),
    "lego": (0.064, 0.064, 0.046),
}

TABLE_TOP_Z: Final = 0.625
"""Height of the table top (pybullet_data ``table/table.urdf`` at the origin)."""

RELATION_AXES: Final[dict[str, tuple[float, float, float]]] = {
    "left": (-1.0, 0.0, 0.0),
    "right": (1.0, 0.0, 0.0),
    "behind": (0.0, 1.0, 0.0),
    "front": (0.0, -1.0, 0.0),
}
RELATION_THRESHOLD: Final = 0.075
"""Object j is R of object i iff (p_j - p_i) . axis(R) > RELATION_THRESHOLD (the original's)."""

EXTREME_MARGIN: Final = 0.04
"""A superlative (``extreme``) names the k-th object towards a side only when it is more
than this far (metres, along that side's axis) from the objects ranked next to it."""

ORDINALS: Final = ("1", "2", "3", "4", "5", "6", "7")
"""The ranks ``extreme`` takes: 1 is the most (the leftmost), 2 the second from that side."""

PHENOMENA: Final = (
    "negation", "prohibition", "question", "absent", "ambiguous", "two_sentence",
    "ellipsis", "correction", "superlative",
)
"""The meaning phenomena of the semantics split (``docs/semantics.md``)."""

ABSTAIN_VALUES: Final = ("no action", "not feasible")
"""Why an instruction must not be carried out: it asks for nothing (a prohibition, a
question, a remark), or it cannot be (a referent the scene lacks or cannot tell apart)."""

PLACEMENT_MARGIN: Final = 0.03
"""Gap between the footprints of a moved object and its reference for left/right moves."""


@dataclass(frozen=True)
class Area:
    """A named axis-aligned rectangle on the table top (object centres), in metres."""

    name: str
    x_min: float
    x_max: float
    y_min: float
    y_max: float

    def contains(self, x: float, y: float) -> bool:
        """Whether the point (x, y) lies inside the rectangle (borders included)."""
        return self.x_min <= x <= self.x_max and self.y_min <= y <= self.y_max

    def to_dict(self) -> dict[str, object]:
        """Plain JSON-able form: ``{"name", "x": [min, max], "y": [min, max]}``."""
        return {"name": self.name, "x": [self.x_min, self.x_max], "y": [self.y_min, self.y_max]}


MIN_OBJECTS: Final = 3
"""Fewest objects in a scene."""

MAX_OBJECTS: Final = 15
"""Most objects in a scene (all in view, with the minimum spacing)."""

MAX_STEPS: Final = 7
"""Most steps in a program (the program sampler's and the templates' limit)."""

SAMPLING_AREA: Final = Area("sampling", -0.30, 0.30, -0.20, 0.20)
"""Where initial object centres are sampled."""

TARGET_AREA: Final = Area("target", -0.36, 0.36, -0.22, 0.22)
"""Where a moved object's centre may land: on the table, in the camera's view and in reach."""


def vocabulary_dict() -> dict[str, object]:
    """The vocabulary as plain JSON-able data (stored in every data file's attributes)."""
    return {
        "shapes": list(SHAPES),
        "colours": list(COLOURS),
        "actions": list(ACTIONS),
        "relations": list(RELATIONS),
        "phrasings": list(PHRASINGS),
        "extents": {k: list(v) for k, v in EXTENTS.items()},
        "table_top_z": TABLE_TOP_Z,
        "relation_threshold": RELATION_THRESHOLD,
        "units": {"length": "m", "quaternion": "xyzw", "image_box": "pixel xyxy", "depth": "m"},
    }
