"""Where the environment's observed ``boxes`` come from: the gold, or a detector.

``boxes="gold"`` gives the current amodal boxes of the simulation (scene order: row ``i``
is object ``i``). ``boxes="classical"`` (``classical-v1``, numpy and scipy) or
``boxes="learned"`` (``detector-v1``, its shipped checkpoint; torch) run that detector on
the current RGB-D image at every observation, as ``nsrmp-bench detect`` runs it on the
initial one: rows are detections in score order (not scene order), and the observation
also holds their ``box_scores``. The observation space states which: only a detector's
observations have ``box_scores``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.detection.detections import Detections
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.geometry.camera import Camera

__all__ = ["BOXES", "DETECTOR_BOXES", "Detector", "check_boxes", "detected_rows",
           "make_detector", "space_entries"]

DETECTOR_BOXES: Final = ("classical", "learned")
"""``boxes=`` values that run a detector on every observation."""
BOXES: Final = (None, "gold", *DETECTOR_BOXES)
"""Every accepted ``boxes=`` value."""

Detector = Callable[[NDArray[np.uint8], NDArray[np.float32], Camera], Detections]
"""(current RGB, current depth, camera) -> the detections of that image."""


def check_boxes(boxes: object) -> str | None:
    """``boxes`` if it is one of :data:`BOXES`, else :class:`InvalidArgument` with the fix."""
    if boxes is None or (isinstance(boxes, str) and boxes in BOXES):
        return boxes
    msg = (f"boxes={boxes!r} is not one of {list(BOXES)}; use None (no boxes), 'gold' (the "
           "current gold boxes), 'classical' (classical-v1 detections) or 'learned' "
           "(detector-v1 detections, needs torch)")
    raise InvalidArgument(msg)


def _classical(rgb: NDArray[np.uint8], depth: NDArray[np.float32], camera: Camera
               ) -> Detections:
    from nsrmp_bench.detection.classical import classical_detect

    return classical_detect("observation", rgb, depth, camera)


def _learned() -> Detector:
    from nsrmp_bench._optional import require

    torch = require("torch")
    from nsrmp_bench.detection.height import height_map
    from nsrmp_bench.reference_model.checkpoints import shipped_checkpoint
    from nsrmp_bench.reference_model.detector import MODEL_ID, DetectorPredictor, detect_scenes
    from nsrmp_bench.reference_model.detector.scenes import Scenes

    model = DetectorPredictor.from_checkpoint(shipped_checkpoint(MODEL_ID))
    model.set_threads()

    def detect(rgb: NDArray[np.uint8], depth: NDArray[np.float32], camera: Camera
               ) -> Detections:
        scenes = Scenes(
            ["observation"], torch.from_numpy(np.ascontiguousarray(rgb))[None],
            torch.from_numpy(height_map(depth, camera).astype(np.float16))[None],
            [], [], [])
        found: Detections = detect_scenes(model.model, scenes, model.config)[0]
        return found

    return detect


def make_detector(boxes: str) -> Detector:
    """The detector that ``boxes`` (one of :data:`DETECTOR_BOXES`) names."""
    if boxes == "classical":
        from nsrmp_bench._optional import require

        require("scipy.ndimage")  # fail at construction, naming the extra
        return _classical
    if boxes == "learned":
        return _learned()
    msg = f"boxes={boxes!r} names no detector; use one of {list(DETECTOR_BOXES)}"
    raise InvalidArgument(msg)


def detected_rows(found: Detections, rows: int, width: int, height: int
                  ) -> tuple[NDArray[np.float32], NDArray[np.int8], NDArray[np.float32]]:
    """(boxes (rows, 4), mask (rows,), scores (rows,)): the first ``rows`` detections
    (score order), zero rows after them; boxes clipped to the image."""
    k = min(rows, len(found))
    boxes = np.zeros((rows, 4), dtype=np.float32)
    scores = np.zeros(rows, dtype=np.float32)
    mask = np.zeros(rows, dtype=np.int8)
    limit = np.array([width, height, width, height], dtype=np.float32)
    found_boxes = np.asarray(found.boxes, dtype=np.float32).reshape(-1, 4)[:k]
    boxes[:k] = np.clip(found_boxes, 0.0, limit)
    scores[:k] = np.clip(np.asarray(found.scores, dtype=np.float32)[:k], 0.0, 1.0)
    mask[:k] = 1
    return boxes, mask, scores


def space_entries(boxes: str | None, width: int, height: int, rows: int
                  ) -> dict[str, Any]:
    """The observation-space entries of the boxes (none without boxes)."""
    from gymnasium import spaces

    if boxes is None:
        return {}
    high = np.tile(np.array([width, height, width, height], np.float32), (rows, 1))
    out: dict[str, Any] = {
        "boxes": spaces.Box(np.zeros_like(high), high, dtype=np.float32),
        "object_mask": spaces.MultiBinary(rows),
    }
    if boxes in DETECTOR_BOXES:
        out["box_scores"] = spaces.Box(0.0, 1.0, (rows,), np.float32)
    return out
