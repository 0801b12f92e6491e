"""``nsrmp-bench detect``: the initial scene's detected objects of every episode of a part.

Example::

    nsrmp-bench detect --data data/paper-v2/test --out detections.jsonl
    nsrmp-bench score-detections detections.jsonl --data data/paper-v2/test
    nsrmp-bench predict nsrm --boxes detections.jsonl --data data/paper-v2/test --out P.jsonl

``--detector classical`` (the default: ``classical-v1``, depth-and-colour segmentation,
no torch; the better-measured one) or ``learned`` (``detector-v1``: its shipped
checkpoint unless ``--checkpoint`` is given). The file format is in
``nsrmp_bench/detection/detections.py``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.plurals import counted
from nsrmp_bench.storage.atomic import output_file

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    from nsrmp_bench.detection.part_detection import DEFAULT_DETECTOR, DETECTORS

    parser.add_argument("--data", required=True, type=Path,
                        help="one split part's data directory (e.g. data/paper-v2/test)")
    parser.add_argument("--out", required=True, type=output_file, help="detections file (.jsonl)")
    parser.add_argument("--detector", choices=DETECTORS, default=DEFAULT_DETECTOR,
                        help=f"which detector (default {DEFAULT_DETECTOR})")
    parser.add_argument("--checkpoint", type=Path, default=None,
                        help="learned detector checkpoint instead of the shipped one")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def run(args: argparse.Namespace) -> int:
    """Detect and write the file."""
    from nsrmp_bench.detection.part_detection import detect_part

    learned = None
    if args.detector == "learned":
        from nsrmp_bench._optional import require

        require("torch")
        from nsrmp_bench.reference_model.detector import detect_with

        learned = detect_with
    det_id, out, count, seconds = detect_part(args.detector, args.data, args.out,
                                              args.checkpoint, learned)
    if not args.quiet:
        print(f"{det_id}: wrote {out} ({counted(count, 'episode')} in {seconds:.1f} s, "
              f"{count / max(seconds, 1e-9):.1f} images/s including reading)")
    return 0
