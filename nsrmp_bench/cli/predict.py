"""``nsrmp-bench predict``: a learned model's predictions for a split part.

Example::

    nsrmp-bench predict nsrm --data data/paper/test --out nsrm.jsonl
    nsrmp-bench score nsrm.jsonl --data data/paper/test
    nsrmp-bench predict nsrm --boxes detections.jsonl --data data/paper/test --out P.jsonl

Without ``--checkpoint`` the checkpoint shipped inside the package is used; a predictions
file of another checkpoint is named ``--name``, else ``MODEL@RUN-HASH`` (e.g.
``nsrm-v3@nsrm-3f2a9c1e``: the checkpoint's folder and its sha256), never the shipped
model's id. The output is
an ordinary predictions file (grounded program, boxes after each step, final boxes, pick
and place points, 3D positions) that ``check-submission``, ``score``, ``compare``,
``replay`` and ``leaderboard`` take like any other. With ``--boxes`` (a file from
``nsrmp-bench detect``) the model reads the detected initial boxes instead of the gold ones
and writes the detected-objects protocol (``SCORING.md``); its model id is
``MODEL+DETECTOR``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from nsrmp_bench.plurals import counted
from nsrmp_bench.storage.atomic import output_file

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("model", help="model name or id: nsrm, nmn, dense, dense5x (or with its "
                        "version, nsrm-v2)")
    parser.add_argument("--data", required=True, type=Path,
                        help="one split part's data directory (e.g. data/paper/test)")
    parser.add_argument("--out", required=True, type=output_file, help="predictions file to write")
    parser.add_argument("--checkpoint", type=Path, default=None,
                        help="checkpoint (.pt) to use instead of the shipped one")
    parser.add_argument("--name", default=None,
                        help="model name written into the predictions file (default: the "
                        "model id for the shipped checkpoint, MODEL@RUN-HASH for another: "
                        "its folder and sha256); compare, evaluate and the boards show it")
    parser.add_argument("--boxes", type=Path, default=None,
                        help="detections file (from `nsrmp-bench detect`) whose boxes the "
                        "model reads instead of the gold initial boxes")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def run(args: argparse.Namespace) -> int:
    """Predict every episode of the part and write the file."""
    from nsrmp_bench._optional import require
    from nsrmp_bench.reference_model.registry import get_model

    get_model(args.model)  # an unknown or retired model is said before torch is needed
    require("torch")
    from nsrmp_bench.reference_model.part_prediction import predict_part

    t0 = time.perf_counter()
    model_id, out, count = predict_part(args.model, args.data, args.out, args.checkpoint,
                                        args.boxes, name=args.name)
    if not args.quiet:
        print(f"{model_id}: wrote {out} ({counted(count, 'episode')} in "
              f"{time.perf_counter() - t0:.1f} s)")
    return 0
