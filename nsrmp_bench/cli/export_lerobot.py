"""``nsrmp-bench export-lerobot DATA --out DIR``: the split in the LeRobot v3.0 layout.

Example::

    nsrmp-bench export-lerobot data/smoke --out lerobot/smoke
    # with lerobot installed elsewhere:
    #   LeRobotDataset("local/smoke", root="lerobot/smoke")

Teleport splits: one frame per rendered state (fps 1), the RGB image as an image
feature, the object poses as ``observation.state``, the move from each state as
``action`` (pick and place image points) and ``action.step`` (the DSL step). Robot splits
(``robot-v2``): one frame per 30 Hz trajectory sample, the Panda's joint positions as
``observation.state`` and the next sample's as ``action`` (see
``nsrmp_bench.export.lerobot_frames``). The instruction is the task. Written
with pyarrow and datasets (lerobot itself is not needed; see
``nsrmp_bench.export.lerobot``). ``DIR`` must be new or empty; the export is written to a
temporary folder beside it and renamed when complete. Needs the ``export`` extra.
"""

from __future__ import annotations

import argparse
import sys

from nsrmp_bench.cli.export_args import add_arguments

__all__ = ["add_arguments", "run"]


def run(args: argparse.Namespace) -> int:
    """Export and print the totals."""
    from nsrmp_bench.export.lerobot import export_lerobot

    info = export_lerobot(args.data, args.out)
    if not args.quiet:
        print(f"wrote {info['total_episodes']} episode(s), {info['total_frames']} frame(s) "
              f"in the LeRobot {info['codebase_version']} layout into {args.out}",
              file=sys.stderr)
    return 0
