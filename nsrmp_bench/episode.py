"""Episodes: the symbolic part (scene, program, instruction, states) and the rendered part.

What a model may read (the instruction, the initial images and initial boxes) is kept
apart from the targets (later states, boxes, the gold program) by :meth:`Episode.inputs`
and :meth:`Episode.targets`; the storage layer keeps the same split on disk.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.canonical import content_hash
from nsrmp_bench.dsl.program import GroundedStep, Program
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.plurals import counted
from nsrmp_bench.scene import Scene, State, state_from_list, state_to_list
from nsrmp_bench.vocabulary import ABSTAIN_VALUES, PHENOMENA

__all__ = [
    "SCHEMA_VERSION",
    "Episode",
    "Instruction",
    "ObjectTargets",
    "Observations",
    "ReferenceLabel",
    "Rendering",
    "SeedInfo",
    "SymbolicEpisode",
    "Trajectory",
]

SCHEMA_VERSION = "1.0.0"
"""Semantic version of the episode schema, written into every file."""


@dataclass(frozen=True)
class SeedInfo:
    """An instance's randomness: ``SeedSequence(entropy, spawn_key=(index, attempt))``.

    A *sealed* seed belongs to a private part (:mod:`nsrmp_bench.private_parts`): its
    entropy is derived from a secret and is never stored, so it is written as ``null``
    with ``"sealed": true`` and read back as entropy 0.
    """

    entropy: int
    index: int
    attempt: int = 0
    sealed: bool = False

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form."""
        if self.sealed:
            return {"entropy": None, "index": self.index, "attempt": self.attempt,
                    "sealed": True}
        return {"entropy": self.entropy, "index": self.index, "attempt": self.attempt}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SeedInfo:
        """Inverse of :meth:`to_dict`."""
        if data.get("sealed"):
            return cls(0, int(data["index"]), int(data.get("attempt", 0)), sealed=True)
        return cls(int(data["entropy"]), int(data["index"]), int(data.get("attempt", 0)))

    def seal(self) -> SeedInfo:
        """The same seed with its entropy withheld (what a private part stores)."""
        return SeedInfo(0, self.index, self.attempt, sealed=True)

    def generator(self) -> np.random.Generator:
        """The numpy Generator this seed denotes."""
        if self.sealed:
            msg = (f"seed of instance {self.index} is sealed (a private part's entropy is "
                   "never stored); regenerate the part with its secret "
                   "(`nsrmp-bench generate --secret-file`) instead of from the stored seed")
            raise InvalidArgument(msg)
        seq = np.random.SeedSequence(self.entropy, spawn_key=(self.index, self.attempt))
        return np.random.default_rng(seq)


@dataclass(frozen=True)
class Instruction:
    """The natural-language instruction and where it came from."""

    text: str
    template_id: str
    phrasing: str
    lexed: str = ""
    held_out_template: bool = False
    held_out_synonyms: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form."""
        return {
            "text": self.text,
            "template_id": self.template_id,
            "phrasing": self.phrasing,
            "lexed": self.lexed,
            "held_out_template": self.held_out_template,
            "held_out_synonyms": list(self.held_out_synonyms),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Instruction:
        """Inverse of :meth:`to_dict`."""
        return cls(
            text=str(data["text"]),
            template_id=str(data["template_id"]),
            phrasing=str(data["phrasing"]),
            lexed=str(data.get("lexed", "")),
            held_out_template=bool(data.get("held_out_template", False)),
            held_out_synonyms=tuple(str(s) for s in data.get("held_out_synonyms", ())),
        )


@dataclass(frozen=True)
class ReferenceLabel:
    """A reference of step ``step`` (its ``role`` is subject or reference object).

    ``relational`` says the reference uses a relation; ``needed`` says the object's
    attributes alone would have been ambiguous at that step (only meaningful if relational).
    """

    step: int
    role: str
    relational: bool
    needed: bool

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form."""
        return {"step": self.step, "role": self.role, "relational": self.relational,
                "needed": self.needed}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ReferenceLabel:
        """Inverse of :meth:`to_dict`."""
        return cls(int(data["step"]), str(data["role"]), bool(data["relational"]),
                   bool(data["needed"]))


@dataclass(frozen=True)
class SymbolicEpisode:
    """One instance without images: scene, program, instruction and the states it passes."""

    id: str
    generator: str
    seed: SeedInfo
    scene: Scene
    program: Program
    grounded: tuple[GroundedStep, ...]
    instruction: Instruction
    states: tuple[State, ...]
    references: tuple[ReferenceLabel, ...] = ()
    phenomenon: str = ""
    """The meaning phenomenon the instruction shows (``vocabulary.PHENOMENA``; the
    semantics split), or "" for an ordinary instruction."""
    abstain: str = ""
    """The gold decision when the instruction must not be carried out
    (``vocabulary.ABSTAIN_VALUES``: "no action" or "not feasible"; the program is then
    empty), or "" when it must be."""

    def __post_init__(self) -> None:
        if self.phenomenon and self.phenomenon not in PHENOMENA:
            msg = (f"episode {self.id}: phenomenon {self.phenomenon!r}; expected one of "
                   f"{list(PHENOMENA)} or ''")
            raise InvalidArgument(msg)
        if self.abstain and (self.abstain not in ABSTAIN_VALUES or self.grounded):
            msg = (f"episode {self.id}: abstain {self.abstain!r} with {len(self.grounded)} "
                   f"steps; expected one of {list(ABSTAIN_VALUES)} and an empty program")
            raise InvalidArgument(msg)
        if len(self.states) != len(self.grounded) + 1:
            msg = (
                f"episode {self.id}: need steps+1 states (initial and after each step), got "
                f"{len(self.states)} states for {len(self.grounded)} steps"
            )
            raise InvalidArgument(msg)

    @property
    def num_steps(self) -> int:
        """Number of manipulation steps."""
        return len(self.grounded)

    @property
    def num_objects(self) -> int:
        """Number of objects in the scene."""
        return len(self.scene)

    @property
    def relational(self) -> bool:
        """Whether any reference uses a relation."""
        return self.program.relational

    @property
    def moved(self) -> tuple[int, ...]:
        """Sorted indices of the objects moved by some step."""
        return tuple(sorted({s.subject for s in self.grounded}))

    def categories(self) -> dict[str, Any]:
        """The categories every breakdown uses."""
        return {
            "steps": self.num_steps,
            "objects": self.num_objects,
            "relational": self.relational,
            "relation_needed": any(r.needed for r in self.references if r.relational),
            "phrasing": self.instruction.phrasing,
            # the first step's template: multi-step ids ("T01+T08+...") are in the
            # instruction; breaking down by every combination would leave cells of one
            "template": self.instruction.template_id.split("+")[0],
            # only semantics episodes carry it: the other splits keep their bytes
            **({"phenomenon": self.phenomenon} if self.phenomenon else {}),
        }

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form (canonical key order when serialised canonically)."""
        return {
            "id": self.id,
            "generator": self.generator,
            "seed": self.seed.to_dict(),
            "scene": self.scene.to_dict(),
            "program": self.program.to_list(),
            "program_text": self.program.text(),
            "grounded": [s.to_list() for s in self.grounded],
            "instruction": self.instruction.to_dict(),
            "states": [state_to_list(s) for s in self.states],
            "references": [r.to_dict() for r in self.references],
            **({"phenomenon": self.phenomenon} if self.phenomenon else {}),
            **({"abstain": self.abstain} if self.abstain else {}),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SymbolicEpisode:
        """Inverse of :meth:`to_dict`."""
        return cls(
            id=str(data["id"]),
            generator=str(data["generator"]),
            seed=SeedInfo.from_dict(data["seed"]),
            scene=Scene.from_dict(data["scene"]),
            program=Program.from_list(data["program"]),
            grounded=tuple(GroundedStep.from_list(s) for s in data["grounded"]),
            instruction=Instruction.from_dict(data["instruction"]),
            states=tuple(state_from_list(s) for s in data["states"]),
            references=tuple(ReferenceLabel.from_dict(r) for r in data.get("references", ())),
            phenomenon=str(data.get("phenomenon", "")),
            abstain=str(data.get("abstain", "")),
        )

    @property
    def content_hash(self) -> str:
        """sha256 of the canonical JSON."""
        return content_hash(self.to_dict())


F32 = NDArray[np.float32]


@dataclass(frozen=True, eq=False)
class Observations:
    """Rendered images, one per rendered state k = 0 (initial) .. S (after the last step)."""

    rgb: NDArray[np.uint8]  # (S+1, H, W, 3)
    depth: F32  # (S+1, H, W), metres along the optical axis
    segmentation: NDArray[np.int16]  # (S+1, H, W), object index, -1 elsewhere


@dataclass(frozen=True, eq=False)
class ObjectTargets:
    """Per rendered state per object: pose and image-space targets."""

    poses: NDArray[np.float64]  # (S+1, N, 7): position xyz + quaternion xyzw
    boxes_amodal: F32  # (S+1, N, 4) pixel xyxy, projection of the object's 3D box
    boxes_visible: F32  # (S+1, N, 4) pixel xyxy from the mask; NaN where unseen
    visible_fraction: F32  # (S+1, N) visible pixels / area of the projected outline of its 3D box
    depth_centre: F32  # (S+1, N) depth of the 3D box centre, metres


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A robot execution recorded at a fixed rate."""

    time: NDArray[np.float64]  # (T,) seconds since the episode start
    joint_positions: NDArray[np.float64]  # (T, J) radians / metres (fingers)
    ee_pose: NDArray[np.float64]  # (T, 7) end-effector position + quaternion xyzw
    gripper: NDArray[np.float64]  # (T,) finger opening in metres
    step: NDArray[np.int16]  # (T,) index of the step being executed
    joint_names: tuple[str, ...] = ()


@dataclass(frozen=True, eq=False)
class Rendering:
    """The physical, rendered realisation of a symbolic episode."""

    camera: Camera
    observations: Observations | None  # None when read without images
    targets: ObjectTargets
    executor: str = "teleport"
    trajectory: Trajectory | None = None
    physics: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class Episode:
    """A symbolic episode with its optional rendering."""

    symbolic: SymbolicEpisode
    rendering: Rendering | None = None

    @property
    def id(self) -> str:
        """The episode id."""
        return self.symbolic.id

    def __repr__(self) -> str:  # the arrays would print tens of kilobytes
        r = self.rendering
        shown = ("symbolic only" if r is None else
                 counted(len(r.targets.boxes_amodal), "rendered state")
                 + ("" if r.observations is not None else " (read without images)")
                 + (", robot trajectory" if r.trajectory is not None else ""))
        s = self.symbolic
        return (f"Episode({s.id!r}, {counted(len(s.scene.objects), 'object')}, "
                f"{counted(len(s.grounded), 'step')}, {s.instruction.text!r:.80}, {shown})")
