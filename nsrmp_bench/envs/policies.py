"""Policies for the closed-loop environment, and how a policy is named on the command line.

A policy is any callable ``policy(observation) -> action`` (the actions of
:mod:`nsrmp_bench.envs.tabletop`). If it also has a ``reset(observation, info)`` method,
that is called at the start of every episode. Every registered predictor
(:mod:`nsrmp_bench.predictors`: the learned models and the baselines) is a named policy,
by its id or its bare name (the latest version), and its kind says which:

* kind ``baseline`` (``oracle``, ``noop``, ``random``): the baseline's predicted program,
  one DSL step per move, then done (:class:`BaselinePolicy`). It reads what the baseline
  reads from the environment's episode (``oracle`` the gold program: privileged, the upper
  bound; ``noop`` nothing: done at once, the floor).
* kind ``program`` (``nsrm``, ``nmn``; or a model id such as ``nsrm-v2``): a shipped
  program model (torch extra). It reads the instruction, the initial RGB-D and the gold
  boxes (so the environment needs ``boxes="gold"``; ``rollout`` sets it) once, predicts
  its grounded program, and issues it one DSL step per move; each step's target is
  computed by the environment on the real state after the previous move (closed-loop
  execution, the program is not re-planned).
* kind ``dense`` (``dense`` = ``dense-v2``, ``dense5x``, ...): the shipped dense model, a
  pick and a place point per step from the current observation, done when its move would
  change nothing (:mod:`nsrmp_bench.envs.dense_policy`). It reads the observation's boxes,
  gold or a detector's (``rollout`` gives the gold ones unless ``--boxes`` names a
  detector).
* ``oracle-ee``: the gold program as end-effector actions (the environment's
  ``control="ee"``; :mod:`nsrmp_bench.envs.ee_oracle`), privileged like ``oracle``.
* ``module:function``: any importable callable, e.g. ``my_pkg.policies:greedy``. A class
  is instantiated with no arguments. Example::

      # my_policy.py
      def policy(observation):
          return {"done": 1}

      nsrmp-bench rollout my_policy:policy --data data/smoke/test --out p.jsonl

A model registered with :func:`nsrmp_bench.reference_model.registry.register` is a policy
with no other line; a retired one (``nsrm-v1``: :class:`nsrmp_bench.predictors.RetiredPredictor`)
is none, and naming it says which release runs it.
"""

from __future__ import annotations

import importlib
import inspect
import os
import sys
from typing import Any, Protocol

import numpy as np

import nsrmp_bench.baselines  # registers the baselines as predictors
import nsrmp_bench.reference_model.registry  # noqa: F401  (registers the learned models)
from nsrmp_bench.envs.dense_policy import DensePolicy
from nsrmp_bench.errors import InvalidArgument, UnknownId
from nsrmp_bench.predictors import Kind, Predictor, get_predictor, predictors

__all__ = ["BaselinePolicy", "Policy", "ProgramModelPolicy", "check_policy", "make_policy",
           "policy_names", "policy_predictor", "reads_boxes", "reads_gold_boxes"]

POLICY_KINDS = (Kind.PROGRAM, Kind.DENSE, Kind.BASELINE)
SCRIPTED = ("oracle-ee",)
"""Named policies that are no registered predictor: scripted, for one control mode."""
EE_POLICIES = ("oracle-ee",)
"""The named policies that issue end-effector actions (``control="ee"``)."""


class Policy(Protocol):
    """What a rollout calls: the next action for an observation."""

    def __call__(self, observation: dict[str, Any]) -> Any: ...


class BaselinePolicy:
    """A baseline's predicted program, one step per move, then done (the baseline reads the
    environment's episode, as it reads a part's: ``oracle-v1`` its gold program)."""

    def __init__(self, env: Any, baseline_id: str) -> None:
        from nsrmp_bench.baselines.registry import get_baseline

        self.baseline = get_baseline(baseline_id)
        self.env = env.unwrapped
        self._steps: list[tuple[str, int, int]] = []
        self._k = 0

    def reset(self, observation: dict[str, Any], info: dict[str, Any]) -> None:
        """Predict the instance's program (seed 0, as ``nsrmp-bench baseline``)."""
        from nsrmp_bench.baselines.registry import predict

        (prediction,) = predict(self.baseline, [self.env.episode])
        self._steps = [(s.action, s.subject, s.reference) for s in prediction.program or ()]
        self._k = 0

    def __call__(self, observation: dict[str, Any]) -> dict[str, Any]:
        if self._k >= len(self._steps):
            return {"done": 1}
        step = self._steps[self._k]
        self._k += 1
        return {"step": step}


class ProgramModelPolicy:
    """A learned program model's grounded program, one step per move, then done."""

    def __init__(self, env: Any, model_id: str) -> None:
        from nsrmp_bench.reference_model.registry import load_model

        if getattr(env.unwrapped, "boxes_mode", None) != "gold":
            msg = (f"policy {model_id!r} reads the gold boxes: make the environment with "
                   "boxes='gold' (rollout: --boxes gold)")
            raise InvalidArgument(msg)
        from nsrmp_bench.reference_model.base import ProgramPredictionModel

        model = load_model(model_id)
        if not isinstance(model, ProgramPredictionModel):
            msg = (f"policy {model_id!r}: its class {type(model).__name__} "
                   f"({model.kind.value} model) has no programs(items); the closed loop issues "
                   "programs: name a program model (nsrm, nmn, nsrm-v2, ...), or make the "
                   "model subclass ProgramPredictionModel")
            raise InvalidArgument(msg)
        self.model = model
        self.env = env.unwrapped
        self._steps: list[tuple[int, int, int]] = []
        self._k = 0

    def reset(self, observation: dict[str, Any], info: dict[str, Any]) -> None:
        """Predict the program from the initial observation."""
        n = int(np.asarray(observation["object_mask"]).sum())
        item = {"id": str(info["instance"]), "inputs": {
            "instruction": observation["instruction"], "rgb": observation["rgb"],
            "depth": observation["depth"],
            "boxes": np.asarray(observation["boxes"][:n], dtype=np.float32),
            "camera": self.env.camera}}  # this episode's camera (reset sets it)
        program = self.model.programs([item])[0]
        self._steps = [(int(a), int(s), int(r)) for a, s, r in program]
        self._k = 0

    def __call__(self, observation: dict[str, Any]) -> dict[str, Any]:
        if self._k >= len(self._steps):
            return {"done": 1}
        a, s, r = self._steps[self._k]
        self._k += 1
        return {"step": (a, s, r)}


def policy_names() -> list[str]:
    """Every named policy: the ids of the registered predictors of a kind the closed loop
    runs, and their bare names (the latest version)."""
    ids = [p.id for p in predictors(*POLICY_KINDS)]
    return sorted({*ids, *(i.rsplit("-v", 1)[0] for i in ids), *SCRIPTED})


def policy_predictor(name: str) -> Predictor | None:
    """The registered predictor the policy ``name`` runs (None for ``module:function`` and
    the scripted ``oracle-ee``)."""
    if ":" in name or name in SCRIPTED:
        return None
    try:
        return get_predictor(name, *POLICY_KINDS)
    except UnknownId as exc:
        msg = (f"unknown policy {name!r}; use one of {policy_names()} or 'module:function' "
               "naming a callable policy(observation) -> action")
        raise InvalidArgument(msg) from exc


def reads_gold_boxes(name: str) -> bool:
    """Whether the policy ``name`` issues DSL steps over the gold boxes (a program model)."""
    entry = policy_predictor(name)
    return entry is not None and entry.kind is Kind.PROGRAM


def reads_boxes(name: str) -> bool:
    """Whether the policy ``name`` reads the observation's boxes (a program or dense model)."""
    entry = policy_predictor(name)
    return entry is not None and entry.kind in (Kind.PROGRAM, Kind.DENSE)


def check_policy(name: str) -> None:
    """Raise :class:`InvalidArgument` unless ``name`` names a policy (imports it)."""
    if policy_predictor(name) is None and name not in SCRIPTED:
        _load(name)


def make_policy(name: str, env: Any) -> Policy:
    """The policy ``name`` (a registered predictor or ``module:function``) for ``env``."""
    entry = policy_predictor(name)
    if name == "oracle-ee":
        from nsrmp_bench.envs.ee_oracle import OracleEEPolicy

        return OracleEEPolicy(env)
    if entry is None:
        return _load(name)
    if entry.kind is Kind.BASELINE:
        return BaselinePolicy(env, entry.id)
    if entry.kind is Kind.PROGRAM:  # the name as given: its errors say it
        return ProgramModelPolicy(env, name)
    return DensePolicy(env, name)


def _current_directory_on_path() -> None:
    """Find a policy's module in the current directory, as ``python -m`` does: a console
    script's ``sys.path`` starts with its own folder, not the current directory."""
    here = os.getcwd()
    if not any(os.path.abspath(p or os.curdir) == here for p in sys.path):
        sys.path.insert(0, here)


def _load(name: str) -> Policy:
    module_name, sep, attr = name.partition(":")
    if not sep or not module_name or not attr:
        msg = (f"unknown policy {name!r}; use one of {policy_names()} or "
               "'module:function' naming a callable policy(observation) -> action")
        raise InvalidArgument(msg)
    _current_directory_on_path()
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        msg = (f"policy {name!r}: module {module_name!r} cannot be imported ({exc}); put it "
               "in the current directory or on PYTHONPATH, or install it")
        raise InvalidArgument(msg) from exc
    obj: object = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            msg = f"policy {name!r}: {module_name!r} has no attribute {attr!r}"
            raise InvalidArgument(msg)
        obj = getattr(obj, part)
    if inspect.isclass(obj):
        obj = obj()
    if not callable(obj):
        msg = f"policy {name!r} is a {type(obj).__name__}, not a callable"
        raise InvalidArgument(msg)
    policy: Policy = obj
    return policy
