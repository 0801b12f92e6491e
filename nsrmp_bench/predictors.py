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

A *retired* predictor (:class:`RetiredPredictor`) is one whose code has left the package: its
id, kind, description and label stay registered, for the committed predictions, model
cards and board rows that name it, but nothing runs it. Naming it where a predictor is run
(``predict``, ``train``, ``rollout``, ``evaluate``, ``robustness``, ``load_model``) is an
:class:`InvalidArgument` that says which release still runs it and which version replaces
it; the lists of predictors that can run (:func:`predictors`) leave it out, and a bare name
means the latest version that is not retired.

This module imports nothing of torch, the models or the generators.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Protocol

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.versioned_ids import resolve_id

__all__ = ["PREDICTORS", "Kind", "Predictor", "RetiredPredictor", "get_predictor",
           "predictors", "refuse_retired", "register_predictor"]


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


@dataclass(frozen=True)
class RetiredPredictor:
    """A predictor whose code has left the package (see the module doc): what the boards,
    cards and tables say of it, the last release that runs it and the version to run
    instead."""

    id: str
    kind: Kind
    description: str
    release: str  # the last nsrmp-bench release that runs it ("0.2.0")
    successor: str  # the id to run instead ("nsrm-v3")
    label: str = ""  # said beside the id wherever its results are shown

    def error(self) -> InvalidArgument:
        """What naming it where predictors run raises: the release that has its code and
        checkpoint, what stays, and the version to pass instead."""
        name, install = self.id.rsplit("-v", 1)[0], f"nsrmp-bench[torch]=={self.release}"
        msg = (f"{self.id} was retired after nsrmp-bench {self.release}, the last release "
               f"with its code and checkpoint (pip install \"{install}\" runs it); its "
               "committed predictions, model card and board rows stay. The current version "
               f"is {self.successor}: pass {self.successor} (or {name}) instead")
        return InvalidArgument(msg)


PREDICTORS: dict[str, Predictor] = {}
"""Predictor id -> its entry (baselines, learned models and the retired ones share one id
space)."""


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


def predictors(*kinds: Kind, retired: bool = False) -> list[Predictor]:
    """The registered predictors of ``kinds`` (every kind when none is given) that can run,
    by id; the retired ones instead when ``retired``."""
    return [p for _, p in sorted(PREDICTORS.items())
            if (not kinds or p.kind in kinds) and isinstance(p, RetiredPredictor) == retired]


def refuse_retired(name: str) -> None:
    """Raise the :class:`RetiredPredictor`'s error if ``name`` is a retired id."""
    entry = PREDICTORS.get(name)
    if isinstance(entry, RetiredPredictor):
        raise entry.error()


def get_predictor(name: str, *kinds: Kind) -> Predictor:
    """The predictor ``name`` (an id, or a bare name meaning its latest version) among
    those of ``kinds`` (every kind when none is given) that can run; a retired id is an
    :class:`InvalidArgument` naming the release that runs it."""
    refuse_retired(name)
    known = {p.id: p for p in predictors(*kinds)}
    what = " or ".join(k.value for k in kinds) + " predictor" if kinds else "predictor"
    return known[resolve_id(name, known, what)]
