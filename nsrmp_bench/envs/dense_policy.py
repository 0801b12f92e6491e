"""The dense models as a closed-loop policy: a pick and a place point per step.

At every step a registered dense model (kind ``dense``: ``dense`` = ``dense-v2``, or
``dense5x-v2``, or one registered from outside) reads the *current*
observation (instruction, RGB-D and boxes) as its open-loop predictor reads an episode's
initial one, and returns its pick (the centre of the box its pick heatmap's peak falls in)
and its place (the peak of its place heatmap) as a pick-and-place action. The boxes are
the observation's: the gold ones (``boxes="gold"``) or a detector's (``boxes="classical"``
/ ``"learned"``); the model uses them only to snap the pick to an object.

Its first move is always made: on the initial state its action is what ``nsrmp-bench
predict dense`` predicts for the episode (the open-loop baseline, one move), so the
closed loop differs only by what it does after that. From the second move on it says
done when its own move would change nothing: the place point lies inside the current box
of the object it picks (on the goal state a model that learnt the task points at the
moved object where it already is). The environment truncates it after the instruction's
step count plus the margin otherwise.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nsrmp_bench.errors import InvalidArgument

__all__ = ["DensePolicy"]


class DensePolicy:
    """A shipped dense model's pick and place on the current observation, every step."""

    def __init__(self, env: Any, model_id: str) -> None:
        mode = getattr(env.unwrapped, "boxes_mode", None)
        if mode is None:
            msg = (f"policy {model_id!r} reads boxes to snap its pick to an object: make the "
                   "environment with boxes='gold', 'classical' or 'learned' (rollout: "
                   "--boxes gold|classical|learned)")
            raise InvalidArgument(msg)
        from nsrmp_bench.reference_model.contract import Kind
        from nsrmp_bench.reference_model.registry import MODELS, get_model, load_model

        entry = get_model(model_id)
        if entry.kind is not Kind.DENSE:
            dense = sorted(k for k, e in MODELS.items() if e.kind is Kind.DENSE)
            msg = (f"policy {model_id!r} is a {entry.kind.value} model; the dense policy "
                   f"runs a dense model ({', '.join(dense)})")
            raise InvalidArgument(msg)
        from nsrmp_bench.reference_model.base import PredictionModel

        model = load_model(entry.id)
        assert isinstance(model, PredictionModel)
        self.model = model
        self.model_id = entry.id
        self._instance = ""
        self.moves = 0

    def reset(self, observation: dict[str, Any], info: dict[str, Any]) -> None:
        """Start an instance (the id names the model's items)."""
        self._instance = str(info["instance"])
        self.moves = 0

    def __call__(self, observation: dict[str, Any]) -> dict[str, Any]:
        n = int(np.asarray(observation["object_mask"]).sum())
        if n == 0:  # nothing seen: nothing to pick
            return {"done": 1}
        boxes = np.asarray(observation["boxes"][:n], dtype=np.float64)
        item = {"id": f"{self._instance}#{self.moves}", "inputs": {
            "instruction": observation["instruction"], "rgb": observation["rgb"],
            "depth": observation["depth"], "boxes": boxes}}
        subject, pick, place = self._pick_and_place(item, boxes)
        x0, y0, x1, y1 = boxes[subject]
        if self.moves > 0 and x0 <= place[0] <= x1 and y0 <= place[1] <= y1:
            return {"done": 1}
        self.moves += 1
        return {"pick": pick, "place": place, "done": 0}

    def _pick_and_place(self, item: dict[str, Any], boxes: np.ndarray[Any, Any]
                        ) -> tuple[int, tuple[float, float], tuple[float, float]]:
        """The picked object, the pick and the place point: from the shipped dense models'
        heatmaps (``infer``), or from any dense model's prediction (its ``pick`` and
        ``place``; the picked object is the box whose centre is nearest the pick)."""
        from nsrmp_bench.reference_model.dense import DenseV2Predictor

        if isinstance(self.model, DenseV2Predictor):
            _, res = self.model.infer([item])
            return (int(res.subjects[0]), (float(res.picks[0, 0]), float(res.picks[0, 1])),
                    (float(res.places[0, 0]), float(res.places[0, 1])))
        import torch

        inputs = {**item["inputs"], "boxes": torch.as_tensor(boxes, dtype=torch.float32)}
        (prediction,) = self.model.predict([{**item, "inputs": inputs}])
        if prediction.pick is None or prediction.place is None:
            msg = (f"dense model {self.model_id!r} predicted no pick and place for "
                   f"{item['id']!r}; a dense model's predict gives both")
            raise InvalidArgument(msg)
        pick = (float(prediction.pick[0]), float(prediction.pick[1]))
        centres = (boxes[:, :2] + boxes[:, 2:]) / 2
        subject = int(np.argmin(((centres - np.asarray(pick)) ** 2).sum(axis=1)))
        return subject, pick, (float(prediction.place[0]), float(prediction.place[1]))
