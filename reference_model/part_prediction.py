"""Running a learned model over one split part into a predictions file.

The ``predict`` command and ``evaluate`` both call :func:`predict_part`; the file it
writes is an ordinary predictions file that the public scorer reads.
"""

from __future__ import annotations

from pathlib import Path

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.split_root import resolve_part

__all__ = ["predict_part"]


def predict_part(model_name: str, data: Path, out: Path,
                 checkpoint: Path | None = None) -> tuple[str, Path, int]:
    """Predict every episode of the part ``data`` into ``out``.

    Returns the model id, the file written and the number of episodes.
    """
    from nsrmp_bench.dataset import EpisodeDataset
    from nsrmp_bench.reference_model.predictions import write_model_predictions
    from nsrmp_bench.reference_model.registry import load_model

    if not data.exists():
        msg = f"--data {data} does not exist; pass a split part's data directory"
        raise InvalidArgument(msg)
    model = load_model(model_name, checkpoint)
    if not hasattr(model, "predict"):
        msg = (f"{model.model_id} makes images, not a predictions file; run it over one "
               "with `nsrmp-bench reconstruct P.jsonl --data DATA --out DIR`")
        raise InvalidArgument(msg)
    ds = EpisodeDataset(resolve_part(data))
    items = [ds[i] for i in range(len(ds))]
    first = ds.collection.episode(0, images=False).rendering
    if first is None:
        msg = (f"{data} holds symbolic episodes without rendering; the learned models "
               "read the initial image and boxes: generate the split with rendering")
        raise InvalidArgument(msg)
    written = write_model_predictions(out, ds.collection.split, model.model_id,
                                      model.predict(items, first.camera),
                                      {"checkpoint": model.checkpoint.name})
    return str(model.model_id), written, len(items)
