"""``nsrmp-bench leaderboard --data ROOT``: rebuild the static leaderboards.

Example::

    nsrmp-bench generate --split paper-v2 --out data/paper-v2 --part test
    nsrmp-bench leaderboard --data data           # data/<split id>/<part>/

Scores every entry of ``leaderboards/entries/`` with the public scorer and writes
``leaderboards/<split>-<part>.md`` and ``.json``, then the static site
``leaderboards/site/`` (open ``leaderboards/site/index.html`` from disk): one sortable page
per board, a model card per entry, ``summary.json``, the generalisation figures (the
README's) and the paper's tables, with copies of the model cards it links; its pages link
the predictions files in ``leaderboards/predictions/`` (publish ``leaderboards/`` whole;
``--site DIR`` outside it copies them into ``DIR/predictions/``). The site needs the
``plot`` extra; ``--no-site`` skips it, and ``--site-only`` redraws the site from the
committed boards and ``site/summary.json`` without data or scoring::

    nsrmp-bench leaderboard --site-only
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.leaderboard import build
from nsrmp_bench.plurals import counted
from nsrmp_bench.results.publish import publish, rebuild_site
from nsrmp_bench.storage.atomic import output_dir

__all__ = ["add_arguments", "run"]

_REPO_BOARDS = Path(__file__).resolve().parents[2] / "leaderboards"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("--data", type=Path, default=None,
                        help="root holding <split id>/<part>/ data directories (required "
                             "unless --site-only)")
    parser.add_argument("--entries", type=Path, default=_REPO_BOARDS / "entries",
                        help="directory of entry files (default: the repository's)")
    parser.add_argument("--out", type=output_dir, default=_REPO_BOARDS,
                        help="where the boards are written (default: the repository's)")
    parser.add_argument("--site", type=output_dir, default=None,
                        help="where the static site is written (default: OUT/site)")
    parser.add_argument("--no-site", action="store_true",
                        help="write the boards only (no site, no figures, no matplotlib)")
    parser.add_argument("--site-only", action="store_true",
                        help="redraw the site from the boards in OUT and SITE/summary.json "
                             "(no data, no scoring)")


def run(args: argparse.Namespace) -> int:
    """Build and print where each board went."""
    site = args.site if args.site is not None else args.out / "site"
    if args.site_only:
        written = rebuild_site(args.entries, args.out, site)
        print(f"site: {site / 'index.html'} ({counted(len(written), 'file')})")
        return 0
    if args.data is None:
        msg = ("--data ROOT is required to score the entries (or pass --site-only to redraw "
               "the site from the committed boards)")
        raise InvalidArgument(msg)
    if args.no_site:
        boards = build(args.entries, args.data, args.out)
    else:
        boards, written = publish(args.entries, args.data, args.out, args.site)
        print(f"site: {site / 'index.html'} ({counted(len(written), 'file')})")
    for split, rows in sorted(boards.items()):
        best = rows[0]
        print(f"{split}: {len(rows)} rows -> {args.out / (split.replace('/', '-') + '.md')} "
              f"(top: {best['model']}, IoU-M {best['metrics']['iou_m'][0]:.3f})")
    return 0
