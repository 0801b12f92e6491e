"""Running a detector over one split part into a detections file (the ``detect`` verb).

``learned`` is ``detector-v1`` (torch; the shipped checkpoint unless one is given),
``classical`` the depth-and-colour segmentation ``classical-v1`` (numpy and scipy).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path

from nsrmp_bench.detection.classical import CLASSICAL_ID, classical_detect
from nsrmp_bench.detection.detections import Detections, write_detections
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.split_root import resolve_part

__all__ = ["DEFAULT_DETECTOR", "DETECTORS", "detect_part"]

DETECTORS = ("learned", "classical")
DEFAULT_DETECTOR = "classical"
"""The better-measured detector on paper-v2/test: AP@0.5 ties (0.990 both), the classical
one's boxes are tighter (AP@[.5:.95] 0.816 against 0.568) and NSRM scores higher on them
(IoU-M 0.325 against 0.298); see reference_model/detector/MODEL_CARD.md."""


def _classical(data: Path) -> Iterator[Detections]:
    from nsrmp_bench.storage.reader import input_camera
    from nsrmp_bench.storage.reader import open as open_collection

    col = open_collection(data)
    for i in range(len(col)):
        inp = col.read_inputs(i)
        camera = input_camera(inp, inp["id"])  # refuses an episode without rendering
        yield classical_detect(str(inp["id"]), inp["rgb"], inp["depth"], camera)


LearnedDetector = Callable[[Path, "Path | None"],
                           tuple[str, Iterator[Detections], dict[str, object]]]
"""Runs the learned detector over a part: (part, checkpoint or None for the shipped one)
to (detector id, detections, header extras). The core does not import the learned models:
the caller passes it (the command line passes ``reference_model.detector.detect_with``)."""


def detect_part(detector: str, data: Path, out: Path, checkpoint: Path | None = None,
                learned: LearnedDetector | None = None) -> tuple[str, Path, int, float]:
    """Detect the initial objects of every episode of ``data`` into ``out``.

    Returns the detector id, the file, the number of episodes and the seconds spent
    detecting (reading the images included). ``detector="learned"`` runs ``learned``.
    """
    if detector not in DETECTORS:
        msg = f"--detector {detector!r} is not one of {list(DETECTORS)}"
        raise InvalidArgument(msg)
    if not data.exists():
        msg = f"--data {data} does not exist; pass a split part's data directory"
        raise InvalidArgument(msg)
    from nsrmp_bench.storage.reader import open as open_collection

    part = resolve_part(data)
    split = open_collection(part).split or "unknown"
    extra: dict[str, object] = {}
    t0 = time.perf_counter()
    if detector == "learned":
        if learned is None:
            msg = "the learned detector is not given: pass learned=... (the CLI does)"
            raise InvalidArgument(msg)
        det_id, found, extra = learned(part, checkpoint)
        dets = list(found)
    else:
        if checkpoint is not None:
            msg = "--checkpoint is for the learned detector; the classical one has none"
            raise InvalidArgument(msg)
        dets = list(_classical(part))
        det_id = CLASSICAL_ID
    seconds = time.perf_counter() - t0
    written = write_detections(out, split, det_id, dets, extra)
    return det_id, written, len(dets), seconds
