"""``nsrmp-bench predict``: a learned model's predictions for a split part.

Example::

    nsrmp-bench predict nsrm --data data/paper/test --out nsrm.jsonl
    nsrmp-bench score nsrm.jsonl --data data/paper/test

Without ``--checkpoint`` the checkpoint shipped inside the package is used. The output is
an ordinary predictions file (grounded program, boxes after each step, final boxes, pick
and place points, 3D positions) that ``check-submission``, ``score``, ``compare``,
``replay`` and ``leaderboard`` take like any other.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.split_root import resolve_part

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("model", help="model name or id (nsrm, nsrm-v1)")
    parser.add_argument("--data", required=True, type=Path,
                        help="one split part's data directory (e.g. data/paper/test)")
    parser.add_argument("--out", required=True, type=Path, help="predictions file to write")
    parser.add_argument("--checkpoint", type=Path, default=None,
                        help="checkpoint (.pt) to use instead of the shipped one")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def run(args: argparse.Namespace) -> int:
    """Predict every episode of the part and write the file."""
    from nsrmp_bench.dataset import EpisodeDataset
    from nsrmp_bench.reference_model import predictions as writer
    from nsrmp_bench.reference_model import registry

    if not args.data.exists():
        msg = f"--data {args.data} does not exist; pass a split part's data directory"
        raise InvalidArgument(msg)
    t0 = time.perf_counter()
    model = registry.load_model(args.model, args.checkpoint)
    ds = EpisodeDataset(resolve_part(args.data))
    items = [ds[i] for i in range(len(ds))]
    first = ds.collection.episode(0, images=False).rendering
    if first is None:
        msg = (f"{args.data} holds symbolic episodes without rendering; the learned models "
               "read the initial image and boxes: generate the split with rendering")
        raise InvalidArgument(msg)
    split = ds.collection.split
    out = writer.write_model_predictions(args.out, split, model.model_id,
                                  model.predict(items, first.camera),
                                  {"checkpoint": model.checkpoint.name})
    if not args.quiet:
        print(f"{model.model_id}: wrote {out} ({len(items)} episodes in "
              f"{time.perf_counter() - t0:.1f} s)")
    return 0
