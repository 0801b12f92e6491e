"""The NSRM v2 configuration: sizes, stages and optimisation, one frozen dataclass."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from nsrmp_bench.reference_model.contract import ModelConfig

__all__ = ["NSRM2Config"]


@dataclass(frozen=True)
class NSRM2Config(ModelConfig):
    """Everything that shapes an NSRM v2 run; stored in every checkpoint."""

    ABSENT: ClassVar[Mapping[str, Any]] = {
        "object_sizes": False, "augment": False, "relation_after_head": False,
        "splitter_joins": 0, "joint_decay": False, "members": 1,
        "filter_link": "logsigmoid", "splitter_gap": 3, "previous_after_link": False,
        "contiguous_references": False}
    LINKS: ClassVar[tuple[str, ...]] = ("logsigmoid", "linear", "leaky")

    concept_dim: int = 32
    object_sizes: bool = True  # perception reads each object's estimated size (metres)
    augment: bool = True  # training crops shifted and scaled a little (perception)
    # how a word's concept score x of an object enters a reference's conjunction:
    # "logsigmoid" log sigmoid(x), a log-probability (its gradient vanishes once x is
    # large: a word true of an object it should not be cannot unlearn it); "linear" x
    # itself (a log-linear product of experts); "leaky" log sigmoid(x) + x / 10
    filter_link: str = "leaky"
    # a word's affinity for the object the previous step moved ("it") is added after
    # filter_link (a log-linear factor that no saturation bounds), not inside it
    previous_after_link: bool = True
    # a reference is one phrase: its relation and anchor words end where the other
    # reference's head begins after this reference's head (ConceptStepModel.step)
    contiguous_references: bool = True
    word_dim: int = 32
    hidden: int = 64
    ordered_roles: bool = True  # a reference reads head, relation, anchor in that order
    # a word is a reference's relation only after the reference's head began
    relation_after_head: bool = True
    # the joint stage's splitter also reads each instruction followed by up to this many
    # more (see program/training.py joint_loss): longer instructions than training has
    splitter_joins: int = 2
    # the fewest tokens a step has, less one: boundary peaks closer than this are one
    # boundary (Splitter.peaks); 3, the splitter's window, before it was a setting
    splitter_gap: int = 5
    # stages (see reference_model/program/training.py)
    epochs_warmup: int = 2  # first stage: see StepModel.warmup_parameters
    epochs_single: int = 14  # one-step programs on episodes where one box changed
    epochs_joint: int = 5  # every episode: splits and one- or two-step programs
    batch_size: int = 32
    lr: float = 1e-2
    joint_lr_scale: float = 0.5  # the joint stage's learning rate, times lr
    # the joint stage's learning rate falls to 0 on a half cosine (reference_model/training.py)
    joint_decay: bool = True
    # models trained apart (seeds seed*members+k), one process each, read as one: the
    # mean of their log-probabilities (reference_model/program/ensemble.py)
    members: int = 3
    threads: int = 1  # torch threads per process (each member trains in its own)

    def validate(self) -> None:
        super().validate()
        self.require(self.members >= 1, "members", "at least 1")
        self.require(self.filter_link in self.LINKS, "filter_link", f"one of {self.LINKS}")
        self.require(self.splitter_gap >= 3, "splitter_gap", "at least 3 (the splitter's window)")
