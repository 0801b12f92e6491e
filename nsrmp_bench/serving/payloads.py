"""Observations and actions as the protocol's payloads carry them, and back.

An observation payload is the environment's observation with the RGB image under
``images.main`` and the instruction also under ``task_description`` (vla-eval's
recommended field names, so its model servers find them); everything else keeps its
name (``depth``, ``instruction``, ``camera``, ``boxes``, ``object_mask``, ``box_scores``,
and in the end-effector mode ``proprio``). An action payload is the environment's action
as a map (a :class:`~nsrmp_bench.dsl.program.GroundedStep` becomes ``{"step": [action,
subject, reference]}``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.errors import PolicyServerError

__all__ = ["action_from_payload", "action_payload", "observation_from_payload",
           "observation_payload"]


def observation_payload(observation: Mapping[str, Any]) -> dict[str, Any]:
    """The payload of an ``observation`` message for an environment observation."""
    out = {k: v for k, v in observation.items() if k != "rgb"}
    if "rgb" in observation:
        out["images"] = {"main": observation["rgb"]}
    out["task_description"] = observation["instruction"]
    if "proprio" in observation:
        out["state"] = observation["proprio"]  # vla-eval's name for proprioception
    return out


def observation_from_payload(payload: Mapping[str, Any]) -> dict[str, Any]:
    """The environment observation an ``observation`` payload holds."""
    images = payload.get("images", {})
    if not isinstance(images, Mapping):
        msg = (f"an observation payload's images must be a map (images.main: the RGB "
               f"image); got {type(images).__name__}")
        raise PolicyServerError(msg)
    out = {k: v for k, v in payload.items()
           if k not in ("images", "task_description", "state")}
    if "main" in images:
        out["rgb"] = images["main"]
    out.setdefault("instruction", payload.get("task_description", ""))
    return out


def action_payload(action: Any) -> dict[str, Any]:
    """The payload of an ``action`` message for what a policy returned."""
    if isinstance(action, GroundedStep):
        return {"step": [action.action, action.subject, action.reference]}
    if not isinstance(action, Mapping):
        msg = (f"the policy returned a {type(action).__name__} ({action!r:.80}); a policy "
               "returns a dict action ({'pick': ..., 'place': ..., 'done': 0}, {'step': "
               "...}, {'done': 1}, or in the ee mode {'ee': ..., 'gripper': ...})")
        raise PolicyServerError(msg)
    return {str(k): v for k, v in action.items()}


def action_from_payload(payload: Mapping[str, Any], control: str = "pick_place"
                        ) -> dict[str, Any]:
    """The environment action an ``action`` payload holds (the environment checks it).

    A vla-eval model server's ``{"actions": vector}`` (or a chunk of them: its first row)
    is read as ``[pick_u, pick_v, place_u, place_v]`` (pixels) or, with ``control="ee"``,
    ``[dx, dy, dz, dyaw, gripper]``.
    """
    if "actions" not in payload or set(payload) & {"pick", "place", "step", "ee", "done"}:
        return dict(payload)
    try:
        arr = np.asarray(payload["actions"], dtype=np.float64)
        row = arr.reshape(-1, arr.shape[-1])[0] if arr.ndim > 1 else arr.reshape(-1)
    except (TypeError, ValueError, IndexError) as exc:
        msg = f"an action's 'actions' must be a numeric vector, got {payload['actions']!r:.80}"
        raise PolicyServerError(msg) from exc
    need = 5 if control == "ee" else 4
    if row.shape[0] != need:
        what = ("[dx, dy, dz, dyaw, gripper]" if control == "ee"
                else "[pick_u, pick_v, place_u, place_v]")
        msg = f"an 'actions' vector for control {control!r} is {what}; got {row.shape[0]} values"
        raise PolicyServerError(msg)
    if control == "ee":
        return {"ee": row[:4].tolist(), "gripper": float(row[4]), "done": 0}
    return {"pick": row[:2].tolist(), "place": row[2:4].tolist(), "done": 0}
