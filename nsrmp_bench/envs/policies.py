"""Policies for the closed-loop environment, and how a policy is named on the command line.

A policy is any callable ``policy(observation) -> action`` (the actions of
:mod:`nsrmp_bench.envs.tabletop`). If it also has a ``reset(observation, info)`` method,
that is called at the start of every episode. Named policies:

* ``oracle``: the gold grounded program, one DSL step per move, then done. It reads the
  gold program from the environment (privileged: the upper bound, as ``oracle-v1``).
* ``noop``: says done at once (the floor).
* ``nsrm`` / ``nmn`` (the latest versions, v3; or a model id such as ``nsrm-v1``): a
  shipped program model (torch extra). It reads the instruction, the initial RGB-D and
  the gold boxes (so the environment needs ``boxes="gold"``; ``rollout`` sets it) once,
  predicts its grounded program, and issues it one DSL step per move; each step's target
  is computed by the environment on the real state after the previous move (closed-loop
  execution, the program is not re-planned).
* ``dense`` (``dense-v2``; or ``dense-v1``, ``dense5x``/``dense5x-v2``, ``dense5x-v1``):
  the shipped dense baseline, a pick and a place point per step from the current
  observation, done when its move would change nothing
  (:mod:`nsrmp_bench.envs.dense_policy`). It reads the observation's boxes, gold or a
  detector's (``rollout`` gives the gold ones unless ``--boxes`` names a detector).
* ``module:function``: any importable callable, e.g. ``my_pkg.policies:greedy``. A class
  is instantiated with no arguments. Example::

      # my_policy.py
      def policy(observation):
          return {"done": 1}

      nsrmp-bench rollout my_policy:policy --data data/smoke/test --out p.jsonl
"""

from __future__ import annotations

import importlib
import inspect
import os
import sys
from collections.abc import Callable
from functools import partial
from typing import Any, Protocol

import numpy as np

from nsrmp_bench.envs.dense_policy import DENSE_POLICIES, DensePolicy
from nsrmp_bench.errors import InvalidArgument

__all__ = ["BOX_READING", "DENSE_POLICIES", "NAMED_POLICIES", "NoopPolicy", "OraclePolicy",
           "Policy", "ProgramModelPolicy", "check_policy", "make_policy"]

BOX_READING = frozenset({"nsrm", "nsrm-v1", "nsrm-v2", "nsrm-v3", "nmn", "nmn-v1", "nmn-v2",
                         "nmn-v3"})
"""Named policies that read the gold boxes (the environment needs ``boxes="gold"``)."""


class Policy(Protocol):
    """What a rollout calls: the next action for an observation."""

    def __call__(self, observation: dict[str, Any]) -> Any: ...


class OraclePolicy:
    """The gold program, one step per move, then done (reads the gold from ``env``)."""

    def __init__(self, env: Any) -> None:
        self.env = env.unwrapped
        self._k = 0

    def reset(self, observation: dict[str, Any], info: dict[str, Any]) -> None:
        """Start the instance's program from its first step."""
        self._k = 0

    def __call__(self, observation: dict[str, Any]) -> dict[str, Any]:
        program = self.env.episode.symbolic.grounded
        if self._k >= len(program):
            return {"done": 1}
        step = program[self._k]
        self._k += 1
        return {"step": (step.action, step.subject, step.reference)}


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
            msg = (f"policy {model_id!r} is a {model.kind.value} model; the closed loop "
                   "issues programs, so name a program model (nsrm, nmn, nsrm-v1, ...)")
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


class NoopPolicy:
    """Says done at once: the scene stays as it is."""

    def __call__(self, observation: dict[str, Any]) -> dict[str, Any]:
        return {"done": 1}


def _dense(model_id: str, env: Any) -> Policy:
    return DensePolicy(env, model_id)


NAMED_POLICIES: dict[str, Callable[[Any], Policy]] = {
    "oracle": OraclePolicy,
    "noop": lambda env: NoopPolicy(),
    "nsrm": lambda env: ProgramModelPolicy(env, "nsrm"),  # the registry's latest version
    "nsrm-v1": lambda env: ProgramModelPolicy(env, "nsrm-v1"),
    "nsrm-v2": lambda env: ProgramModelPolicy(env, "nsrm-v2"),
    "nsrm-v3": lambda env: ProgramModelPolicy(env, "nsrm-v3"),
    "nmn": lambda env: ProgramModelPolicy(env, "nmn"),
    "nmn-v1": lambda env: ProgramModelPolicy(env, "nmn-v1"),
    "nmn-v2": lambda env: ProgramModelPolicy(env, "nmn-v2"),
    "nmn-v3": lambda env: ProgramModelPolicy(env, "nmn-v3"),
    **{name: partial(_dense, name) for name in sorted(DENSE_POLICIES)},
}
"""Policy name -> factory taking the environment."""


def check_policy(name: str) -> None:
    """Raise :class:`InvalidArgument` unless ``name`` names a policy (imports it)."""
    if name not in NAMED_POLICIES:
        _load(name)


def make_policy(name: str, env: Any) -> Policy:
    """The policy ``name`` (a named policy or ``module:function``) for ``env``."""
    if name in NAMED_POLICIES:
        return NAMED_POLICIES[name](env)
    return _load(name)


def _current_directory_on_path() -> None:
    """Find a policy's module in the current directory, as ``python -m`` does: a console
    script's ``sys.path`` starts with its own folder, not the current directory."""
    here = os.getcwd()
    if not any(os.path.abspath(p or os.curdir) == here for p in sys.path):
        sys.path.insert(0, here)


def _load(name: str) -> Policy:
    module_name, sep, attr = name.partition(":")
    if not sep or not module_name or not attr:
        msg = (f"unknown policy {name!r}; use one of {sorted(NAMED_POLICIES)} or "
               "'module:function' naming a callable policy(observation) -> action")
        raise InvalidArgument(msg)
    _current_directory_on_path()
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        msg = (f"policy {name!r}: module {module_name!r} cannot be imported ({exc}); put it "
               "in the current directory or on PYTHONPATH, or install it")
        raise InvalidArgument(msg) from exc
    obj: Any = module
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
