"""``nsrmp-bench leaderboard --data ROOT``: rebuild the static leaderboards.

Example::

    nsrmp-bench generate --split paper-v2 --out data/paper-v2 --part test
    nsrmp-bench leaderboard --data data           # data/<split id>/<part>/

Scores every entry of ``leaderboards/entries/`` with the public scorer and writes
``leaderboards/<split>-<part>.md`` and ``.json``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.leaderboard import build

__all__ = ["add_arguments", "run"]

_REPO_BOARDS = Path(__file__).resolve().parents[2] / "leaderboards"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("--data", type=Path, required=True,
                        help="root holding <split id>/<part>/ data directories")
    parser.add_argument("--entries", type=Path, default=_REPO_BOARDS / "entries",
                        help="directory of entry files (default: the repository's)")
    parser.add_argument("--out", type=Path, default=_REPO_BOARDS,
                        help="where the boards are written (default: the repository's)")


def run(args: argparse.Namespace) -> int:
    """Build and print where each board went."""
    boards = build(args.entries, args.data, args.out)
    for split, rows in sorted(boards.items()):
        best = rows[0]
        print(f"{split}: {len(rows)} rows -> {args.out / (split.replace('/', '-') + '.md')} "
              f"(top: {best['model']}, IoU-M {best['metrics']['iou_m'][0]:.3f})")
    return 0
