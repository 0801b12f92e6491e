"""The one registry of everything that predicts: learned models and baselines, each with its
:class:`Kind`.

Every predictor has an id (``name-vN``), a kind, a one-line description and a label (said
beside the id on boards, e.g. "not CLIPort"). The baselines register here when
:mod:`nsrmp_bench.baselines` is imported, the learned models when
:mod:`nsrmp_bench.reference_model.registry` is (its ``register`` is the one line a new
model adds). What runs a predictor follows from its kind: ``predict`` runs the program and
dense models, ``baseline`` the baselines, and the closed loop derives one policy per
predictor from it (:mod:`nsrmp_bench.envs.policies`: a program model issues its program,
a dense model picks and places every step, a baseline issues its prediction's program).

This module imports nothing of torch, the models or the generators.
"""

from __future__ import annotations

import enum
from typing import Protocol

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.versioned_ids import resolve_id

__all__ = ["PREDICTORS", "Kind", "Predictor", "get_predictor", "predictors",
           "register_predictor"]


class Kind(enum.Enum):
    """What a predictor's inference makes, and so the verb that runs it."""

    PROGRAM = "program"  # a predictions file with a grounded program (NSRM, NMN+)
    DENSE = "dense"  # a predictions file of pick and place points, no program
    BASELINE = "baseline"  # a non-learned predictions file (oracle, noop, random)
    DETECTOR = "detector"  # a detections file (``nsrmp-bench detect``)
    RECONSTRUCTION = "reconstruction"  # images over a predictions file (``reconstruct``)

    @property
    def writes_predictions(self) -> bool:
        """Whether ``nsrmp-bench predict`` runs learned models of this kind."""
        return self in (Kind.PROGRAM, Kind.DENSE)

    @property
    def has_policy(self) -> bool:
        """Whether the closed loop (``rollout``) runs predictors of this kind."""
        return self in (Kind.PROGRAM, Kind.DENSE, Kind.BASELINE)

    def use_after_training(self, name: str, test: str, checkpoint: str) -> str:
        """The command that runs a freshly trained model of this kind."""
        if self is Kind.DETECTOR:
            return f"nsrmp-bench detect --data {test} --out D.jsonl --checkpoint {checkpoint}"
        if self is Kind.RECONSTRUCTION:
            return (f"nsrmp-bench reconstruct P.jsonl --data {test} --out DIR "
                    f"--checkpoint {checkpoint}")
        return (f"nsrmp-bench predict {name} --data {test} --out P.jsonl "
                f"--checkpoint {checkpoint}")


class Predictor(Protocol):
    """A registered predictor: a learned model's entry or a baseline."""

    @property
    def id(self) -> str:
        """``name-vN``."""

    @property
    def kind(self) -> Kind:
        """What it makes."""

    @property
    def description(self) -> str:
        """One line on what it is."""

    @property
    def label(self) -> str:
        """Said beside the id wherever its results are shown ("" for none)."""


PREDICTORS: dict[str, Predictor] = {}
"""Predictor id -> its entry (baselines and learned models share one id space)."""


def register_predictor(entry: Predictor) -> Predictor:
    """Add ``entry`` to :data:`PREDICTORS`; an id registered twice (for another entry) is an
    :class:`InvalidArgument`."""
    known = PREDICTORS.get(entry.id)
    if known is not None and known != entry:
        msg = (f"predictor id {entry.id!r} is registered already ({known.kind.value}: "
               f"{known.description}); give the new {entry.kind.value} a new id")
        raise InvalidArgument(msg)
    PREDICTORS[entry.id] = entry
    return entry


def predictors(*kinds: Kind) -> list[Predictor]:
    """The registered predictors of ``kinds`` (every kind when none is given), by id."""
    return [p for _, p in sorted(PREDICTORS.items()) if not kinds or p.kind in kinds]


def get_predictor(name: str, *kinds: Kind) -> Predictor:
    """The predictor ``name`` (an id, or a bare name meaning its latest version) among
    those of ``kinds`` (every kind when none is given)."""
    known = {p.id: p for p in predictors(*kinds)}
    what = " or ".join(k.value for k in kinds) + " predictor" if kinds else "predictor"
    return known[resolve_id(name, known, what)]
