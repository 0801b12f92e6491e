"""The predictions writer every learned model uses: its programs and predicted object
locations to an ordinary predictions file, which the public scorer reads.

Per episode: ``program`` (grounded steps), ``step_boxes`` (boxes after each step),
``boxes`` (final), ``pick``/``place`` (the first subject's box centre before and after its
step) and ``positions`` (final box centres back-projected at the predicted depth through
the split's camera).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from nsrmp_bench.dsl.program import GroundedStep
from nsrmp_bench.geometry.boxes import box_centres
from nsrmp_bench.geometry.camera import Camera
from nsrmp_bench.scoring.submission import Prediction, SubmissionHeader, write_submission
from nsrmp_bench.vocabulary import ACTIONS

__all__ = ["model_predictions", "write_model_predictions"]


def model_predictions(ids: Sequence[str], initial_boxes: Sequence[np.ndarray],
                      steps: Sequence[Sequence[tuple[int, int, int]]],
                      step_boxes: Sequence[np.ndarray], step_depths: Sequence[np.ndarray],
                      camera: Camera) -> Iterator[Prediction]:
    """Predictions from per-episode steps and per-step boxes (S, N, 4) and depths (S, N).

    Boxes are clipped to the camera's image (a predicted location may fall past its edge).
    """
    limit = np.array([camera.width, camera.height, camera.width, camera.height], float)
    for eid, init, prog, boxes, depth in zip(ids, initial_boxes, steps, step_boxes,
                                             step_depths, strict=True):
        init = np.asarray(init, dtype=np.float64)
        if len(prog) == 0:
            yield Prediction(id=eid, boxes=init, program=(), step_boxes=None)
            continue
        boxes = np.clip(np.asarray(boxes, dtype=np.float64), 0.0, limit)
        grounded = tuple(GroundedStep(ACTIONS[a], int(s), int(r)) for a, s, r in prog)
        s0 = prog[0][1]
        final = boxes[-1]
        positions = camera.backproject(box_centres(final),
                                       np.asarray(depth[-1], dtype=np.float64))
        pick, place = box_centres(init[s0]), box_centres(boxes[0][s0])
        yield Prediction(
            id=eid, boxes=final, program=grounded, step_boxes=boxes,
            pick=(float(pick[0]), float(pick[1])), place=(float(place[0]), float(place[1])),
            positions=positions,
        )


def write_model_predictions(out: str | Path, split: str, model_id: str,
                            predictions: Iterator[Prediction],
                            extra: dict[str, object] | None = None) -> Path:
    """Write ``predictions`` with a header naming the split and the model."""
    header = SubmissionHeader(split=split, model=model_id, extra=dict(extra or {}))
    return write_submission(out, header, predictions)

