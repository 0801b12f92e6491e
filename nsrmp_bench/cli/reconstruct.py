"""``nsrmp-bench reconstruct P.jsonl --data DATA --out DIR [--renderer network|sim]``.

Draws the state after every predicted step of a predictions file (any file with
``step_boxes``: the oracle's, NSRM's, anyone's) and scores it against the simulator's
renders with SSIM, over the whole image and inside the moved objects' boxes. The default
renderer is the learned reconstruction network (``reconstruction-v1``, no simulator);
``--renderer sim`` re-renders the predicted positions in PyBullet (the reference row).
Writes ``DIR/images/<id>/step-<k>.png``, ``DIR/sheets/<id>.png`` (initial, reconstructed
and gold per step) and ``DIR/ssim.json``, and prints the table. Needs the
``reconstruction`` extra (and ``torch``, or ``sim`` for the sim renderer).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.storage.atomic import output_dir

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("predictions", type=Path, help="predictions file with step_boxes")
    parser.add_argument("--data", required=True, type=Path,
                        help="the split's data (a part's directory, or the split root)")
    parser.add_argument("--out", required=True, type=output_dir, help="directory to write")
    parser.add_argument("--renderer", choices=("network", "sim"), default="network",
                        help="network (reconstruction-v1, default) or sim (PyBullet)")
    parser.add_argument("--checkpoint", type=Path, default=None,
                        help="reconstruction checkpoint (default: the shipped one)")
    parser.add_argument("--limit", type=int, default=0,
                        help="only the first N episodes of the file (default 0: all)")
    parser.add_argument("--no-images", action="store_true",
                        help="scores only: write no PNGs or sheets")


def run(args: argparse.Namespace) -> int:
    """Reconstruct, score, print the table and where the files went."""
    from nsrmp_bench._optional import require

    sim_renderer = None
    if args.renderer == "sim":
        require("pybullet")
        from nsrmp_bench.generators.world.sim_renderer import SimRenderer

        sim_renderer = SimRenderer
    else:
        require("torch")
    require("skimage")
    from nsrmp_bench.reference_model.reconstruction.reconstruct import reconstruct_file, table

    result = reconstruct_file(args.predictions, args.data, args.out, renderer=args.renderer,
                              checkpoint=args.checkpoint, limit=args.limit,
                              images=not args.no_images, sim_renderer=sim_renderer)
    print(table(result))
    rate = result["images"] / max(result["seconds"], 1e-9)
    print(f"wrote {args.out / 'ssim.json'}"
          + ("" if args.no_images else f", {args.out / 'images'}, {args.out / 'sheets'}")
          + f" ({result['images']} images in {result['seconds']:.1f} s, {rate:.1f}/s)")
    return 0
