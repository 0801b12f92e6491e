"""``nsrmp-bench show PATH --png SHEET.png [--episode ID]``.

Draws the contact sheet of one stored episode (the instruction, the initial scene, the
scene after each step with every object's box and index, and the grounded step under
each panel) and writes it as a PNG. ``PATH`` is anything :func:`nsrmp_bench.storage.open`
reads: a shard file or a data directory. Needs the ``sim`` extra (OpenCV).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from nsrmp_bench._optional import require
from nsrmp_bench.errors import InvalidArgument

if TYPE_CHECKING:
    from nsrmp_bench.episode import Episode
    from nsrmp_bench.storage.reader import EpisodeCollection


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("path", help="a shard file (*.h5) or a data directory")
    parser.add_argument("--png", required=True, metavar="SHEET.png",
                        help="where to write the contact sheet")
    parser.add_argument("--episode", metavar="ID",
                        help="episode id, or its position in PATH (default: the first)")
    parser.add_argument("--scale", type=int, default=2,
                        help="image enlargement factor for legible labels (default 2)")
    parser.add_argument("--columns", type=int, default=3, help="panels per row (default 3)")


def _pick(collection: EpisodeCollection, episode: str | None) -> Episode:
    if episode is None:
        if len(collection) == 0:
            msg = "PATH holds no episodes; pass a shard or data directory with episodes"
            raise InvalidArgument(msg)
        return collection[0]
    if episode.lstrip("-").isdigit():
        index = int(episode)
        if not -len(collection) <= index < len(collection):
            msg = (f"--episode {index} is out of range: PATH holds {len(collection)} "
                   "episodes; pass a position in that range or an episode id")
            raise InvalidArgument(msg)
        return collection[index]
    return collection.get(episode)


def run(args: argparse.Namespace) -> int:
    """Write the contact sheet and print where it went."""
    cv2 = require("cv2")
    from nsrmp_bench.generators.world import contact_sheet as sheets
    from nsrmp_bench.storage import open as open_storage


    out = Path(args.png)
    if out.suffix.lower() != ".png":
        msg = f"--png must name a .png file, got {str(out)!r}; e.g. --png sheet.png"
        raise InvalidArgument(msg)
    collection = open_storage(args.path)
    try:
        episode = _pick(collection, args.episode)
    finally:
        close = getattr(collection, "close", None)
        if close is not None:
            close()
    image = sheets.contact_sheet(episode, scale=args.scale, columns=args.columns)
    out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(out), image[:, :, ::-1]):
        msg = f"could not write {out}; check that the folder is writable"
        raise InvalidArgument(msg)
    print(f"wrote {out}: episode {episode.id}, {image.shape[1]}x{image.shape[0]} px")
    return 0
