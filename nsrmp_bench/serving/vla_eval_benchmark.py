"""The benchmark as a vla-eval ``StepBenchmark`` (the ``vla-eval`` extra).

Example (vla-eval's runner and connection, any model server that speaks the protocol,
``nsrmp-bench serve`` included)::

    from nsrmp_bench.serving.vla_eval_benchmark import TabletopBenchmark

    bench = TabletopBenchmark(data="data/smoke/test")
    for task in bench.get_tasks():          # one task per instance of the part
        ...                                 # vla-eval runs reset / step / result
    bench.predictions()                     # the achieved scenes, for nsrmp-bench score

Each task is one instance (``name`` and ``instance`` its id, ``suite`` the part's split
id). ``reset`` starts it in ``nsrmp_bench/Tabletop-v0``; ``make_obs`` is the protocol's
observation payload (``images.main``, ``task_description``, ``state`` in the ee mode, and
the rest under the environment's names); ``step`` takes the environment's action dicts, or
vla-eval's ``{"actions": vector}`` (:func:`~nsrmp_bench.serving.payloads.action_from_payload`);
the result is the scorer's success and IoU-M of the achieved scene. The episode ends on
done or the environment's step limit (``get_metadata()["max_steps"]`` bounds it too).
Each finished episode's predictions line is kept: :meth:`TabletopBenchmark.predictions`
returns them for :func:`~nsrmp_bench.scoring.submission.write_submission` and ``score``,
so a vla-eval run is scored by the same public scorer as any other.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from nsrmp_bench._optional import require
from nsrmp_bench.scoring.submission import Prediction
from nsrmp_bench.serving.payloads import action_from_payload, observation_payload

__all__ = ["TabletopBenchmark"]

_base = require("vla_eval.benchmarks.base")
_specs = require("vla_eval.specs")


class TabletopBenchmark(_base.StepBenchmark):  # type: ignore[misc,name-defined]
    """``nsrmp_bench/Tabletop-v0`` as a vla-eval benchmark (see the module)."""

    def __init__(self, data: str | Path | None = None, *, split: str | None = None,
                 part: str = "test", control: str = "pick_place", boxes: str | None = None,
                 executor: str = "teleport", step_margin: int = 2,
                 limit: int | None = None) -> None:
        super().__init__()
        from nsrmp_bench.envs.tabletop import TabletopEnv

        self.env = TabletopEnv(data, split=split, part=part, boxes=boxes, executor=executor,
                               step_margin=step_margin, control=control)
        self.control = control
        ids = list(self.env.source.ids)
        self.ids = ids if limit is None else ids[:limit]
        self.suite = split or str(data)
        self._predictions: dict[str, Prediction] = {}

    # -- the StepBenchmark contract --------------------------------------------------------
    def get_tasks(self) -> list[dict[str, Any]]:
        """One task per instance."""
        return [{"name": i, "instance": i, "suite": self.suite} for i in self.ids]

    def reset(self, task: dict[str, Any]) -> Any:
        """Start the task's instance; its first observation."""
        obs, _ = self.env.reset(options={"instance": task["instance"]})
        return obs

    def step(self, action: dict[str, Any]) -> Any:
        """One environment step of the model server's action."""
        obs, reward, terminated, truncated, info = self.env.step(
            action_from_payload(action, self.control))
        done = bool(terminated or truncated)
        if done:
            prediction = self.env.prediction()
            self._predictions[prediction.id] = prediction
        return _base.StepResult(obs=obs, reward=float(reward), done=done, info=info)

    def make_obs(self, raw_obs: Any, task: dict[str, Any]) -> dict[str, Any]:
        """The protocol's observation payload."""
        return observation_payload(raw_obs)

    def get_step_result(self, step_result: Any) -> dict[str, Any]:
        """The scorer's success and IoU-M of the scene now."""
        info = step_result.info or {}
        iou_m = float(info.get("iou_m", math.nan))
        return {"success": bool(info.get("is_success", False)),
                "iou_m": iou_m if math.isfinite(iou_m) else 1.0,
                "moves": int(info.get("step", 0))}

    def get_metric_keys(self) -> dict[str, str]:
        """Success rate and mean IoU-M."""
        return {"success": "mean", "iou_m": "mean"}

    def get_metadata(self) -> dict[str, Any]:
        """The step limit (the environment's own is the instruction's moves + margin)."""
        from nsrmp_bench.envs.tabletop import EE_STEPS_PER_MOVE
        from nsrmp_bench.vocabulary import MAX_STEPS

        moves = MAX_STEPS + self.env.step_margin + 1
        return {"max_steps": moves * EE_STEPS_PER_MOVE if self.control == "ee" else moves,
                "control": self.control}

    def get_action_spec(self) -> dict[str, Any]:
        """The action vector vla-eval's ``actions`` carries in this mode."""
        dim = _specs.DimSpec
        if self.control == "ee":
            return {"position": dim("position", 3, "delta_xyz", (-0.05, 0.05)),
                    "yaw": dim("yaw", 1, "delta_yaw", (-0.5, 0.5)),
                    "gripper": dim("gripper", 1, "open_positive", (0.0, 1.0))}
        return {"pick": dim("pick", 2, "pixel_uv"), "place": dim("place", 2, "pixel_uv")}

    def get_observation_spec(self) -> dict[str, Any]:
        """What :meth:`make_obs` sends."""
        dim = _specs.DimSpec
        out = {"main": dim("main", 0, "rgb_hwc_uint8"),
               "task_description": dim("task_description", 0, "language")}
        if self.control == "ee":
            out["state"] = dim("state", 12, "ee_xyz_yaw_opening_joints7")
        return out

    def cleanup(self) -> None:
        """Release the PyBullet world."""
        self.env.close()

    # -- for the public scorer -----------------------------------------------------------
    def predictions(self) -> list[Prediction]:
        """The finished episodes' predictions lines, in the part's order."""
        return [self._predictions[i] for i in self.ids if i in self._predictions]
