"""Running a learned model over one split part into a predictions file.

The ``predict`` command and ``evaluate`` both call :func:`predict_part`; the file it
writes is an ordinary predictions file that the public scorer reads.

With ``boxes`` (a detections file, see :mod:`nsrmp_bench.detection.detections`) any model
that reads the initial boxes from its inputs reads the detected boxes in their place, and
the file is written in the detected-objects protocol (each line carries its
``detections``; boxes and program are per detection; the scorer matches them to the gold
objects). Its model id is ``MODEL+DETECTOR`` (e.g. ``nsrm-v3+detector-v1``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.split_root import resolve_part

if TYPE_CHECKING:
    from nsrmp_bench.reference_model.base import PredictionModel

__all__ = ["checkpoint_label", "predict_part", "with_detected_boxes"]


def checkpoint_label(model_id: str, checkpoint: Path) -> str:
    """The model name a predictions file made with ``checkpoint`` carries by default.

    The shipped checkpoint (the same bytes) keeps ``model_id``; any other is named
    ``MODEL_ID@RUN-HASH`` (the checkpoint's folder and the first 8 hex digits of its sha256,
    e.g. ``nsrm-v3@nsrm-3f2a9c1e``), so that ``compare``, ``evaluate`` and the boards never
    take a retrained model for the shipped one.
    """
    from nsrmp_bench.canonical import sha256_file
    from nsrmp_bench.reference_model.checkpoints import shipped_checkpoint

    digest = sha256_file(checkpoint)
    try:
        shipped = sha256_file(shipped_checkpoint(model_id))
    except InvalidArgument:  # none shipped with this installation
        shipped = ""
    if digest == shipped:
        return model_id
    run = checkpoint.resolve().parent.name or "run"
    return f"{model_id}@{run}-{digest[:8]}"


def with_detected_boxes(items: list[dict[str, Any]], boxes: Path, split: str | None
                        ) -> tuple[list[dict[str, Any]], dict[str, Any], str]:
    """``items`` with their initial boxes replaced by the detections of file ``boxes``.

    Returns the items, the detected boxes by episode id and the detector id. An episode
    without a line in the file, or a file for another split, is an error.
    """
    import numpy as np
    import torch

    from nsrmp_bench.detection.detections import read_detections
    from nsrmp_bench.scoring.align import split_matches

    found = read_detections(boxes)
    declared = str(found.header.get("split", ""))
    if split and declared and not split_matches(declared, split):
        msg = (f"--boxes {boxes} holds detections of split {declared!r}, but the data is "
               f"{split!r}; detect on this part first (nsrmp-bench detect --data ...)")
        raise InvalidArgument(msg)
    out, by_id = [], {}
    for item in items:
        d = found.by_id.get(str(item["id"]))
        if d is None:
            msg = (f"--boxes {boxes} has no line for episode {item['id']!r}; detect on the "
                   "whole part (nsrmp-bench detect --data ... --out ...)")
            raise InvalidArgument(msg)
        det = np.asarray(d.boxes, dtype=np.float32).reshape(-1, 4)
        by_id[d.id] = d.boxes
        out.append({**item, "inputs": {**item["inputs"], "boxes": torch.from_numpy(det)}})
    return out, by_id, found.detector


def predict_part(model_name: str, data: Path, out: Path,
                 checkpoint: Path | None = None, boxes: Path | None = None,
                 name: str | None = None) -> tuple[str, Path, int]:
    """Predict every episode of the part ``data`` into ``out``.

    Returns the model name written into the header (``name``, else the model id, or for a
    checkpoint that is not the shipped one :func:`checkpoint_label`; ``+DETECTOR`` with
    ``boxes``),
    the file written and the number of episodes.
    """
    from nsrmp_bench.dataset import EpisodeDataset, shared_camera
    from nsrmp_bench.reference_model.predictions import write_model_predictions
    from nsrmp_bench.reference_model.protocols import shipped_protocol
    from nsrmp_bench.reference_model.registry import load_predictor

    if not data.exists():
        msg = f"--data {data} does not exist; pass a split part's data directory"
        raise InvalidArgument(msg)
    model = load_predictor(model_name, checkpoint)
    ds = EpisodeDataset(resolve_part(data))
    items = [ds[i] for i in range(len(ds))]
    shared_camera(items)  # a part without rendering is refused before any work
    model_id = str(model.model_id)
    extra: dict[str, object] = {"checkpoint": model.checkpoint.name}
    label = name or (checkpoint_label(model_id, Path(checkpoint)) if checkpoint is not None
                     else model_id)
    if label != model_id:
        extra["base_model"] = model_id
        if checkpoint is not None:
            extra["checkpoint"] = str(checkpoint)
        model_id = label
    predictions: Iterator[Any]
    if boxes is None:
        predictions = model.predict(items)
    else:
        items, detected, detector = with_detected_boxes(items, boxes, ds.collection.split)
        model_id = f"{model_id}+{detector}"
        extra.update({"boxes": detector, "detections_file": boxes.name})
        predictions = _on_detections(model, items, detected)
    root = ds.collection.manifest.root_hash if ds.collection.manifest is not None else None
    if checkpoint is None and root is not None:  # the shipped checkpoint: its facts are known
        extra["protocol"] = shipped_protocol(
            str(model.model_id), root, detector=str(extra["boxes"]) if boxes else None,
        ).to_dict()
    written = write_model_predictions(out, ds.collection.split, model_id, predictions, extra)
    return model_id, written, len(items)


def _on_detections(model: PredictionModel, items: list[dict[str, Any]], detected: dict[str, Any]
                   ) -> Iterator[Any]:
    """The model's predictions with their detections; a scene with nothing detected gets
    an empty prediction (no objects, no steps) without running the model."""
    import numpy as np

    from nsrmp_bench.scoring.submission import Prediction

    seen = [it for it in items if len(detected[str(it["id"])])]
    made = {p.id: p for p in model.predict(seen)} if seen else {}
    for it in items:
        eid = str(it["id"])
        if eid in made:
            yield dataclasses.replace(made[eid], detections=detected[eid])
        else:
            yield Prediction(id=eid, boxes=np.zeros((0, 4)), program=(),
                             detections=np.zeros((0, 4)))
