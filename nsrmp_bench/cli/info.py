"""``nsrmp-bench info DATA|SPLIT``: counts per category, as tables.

Examples::

    nsrmp-bench info data/paper/test      # what was generated
    nsrmp-bench info paper-v2             # what the spec asks for, per part
    nsrmp-bench info --spec my-split.json # the same for a custom spec file
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import cast

import pandas as pd
from rich.console import Console
from rich.table import Table

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.plurals import counted
from nsrmp_bench.split_specs import SPLIT_ID_RE, SplitSpec, load_split_file, resolve_split
from nsrmp_bench.storage.manifest import MANIFEST_NAME

__all__ = ["add_arguments", "category_frame", "run"]

CATEGORIES = ("steps", "objects", "relational", "relation_needed", "phrasing", "template")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("target", nargs="?", default=None,
                        help="a data directory / shard, a split id like paper-v2, or a "
                             "split spec file (.json)")
    parser.add_argument("--spec", type=Path, default=None, metavar="PATH",
                        help="a custom split spec file, instead of TARGET")


def category_frame(target: str | SplitSpec) -> pd.DataFrame:
    """Rows of categories with a ``part`` column and an ``instances`` column (how many
    instances each row stands for), for a data directory or shard (one row per instance),
    a split id, a spec file, or a :class:`SplitSpec` (one row per distinct config: instance
    *i* takes the *i*-th cell of its part's cycle, so a count of 10^12 costs no more than
    one cycle)."""
    spec: SplitSpec | None = target if isinstance(target, SplitSpec) else None
    if isinstance(target, str) and (
        (SPLIT_ID_RE.match(target) and not Path(target).exists())
        or (target.endswith(".json") and Path(target).is_file())
    ):
        spec = resolve_split(target)
    if spec is not None:
        rows = []
        for part, ps in spec.parts.items():
            cycles, rest = divmod(ps.count, len(ps.cells()))
            for i in range(min(ps.count, len(ps.cells()))):
                c = spec.config(part, i)
                rows.append({"part": part, "steps": c.steps, "objects": c.objects,
                             "relational": c.relational, "phrasing": c.phrasing,
                             "held_out_language": c.held_out,
                             "held_out_pairs_required": bool(c.required_pairs),
                             "instances": cycles + (1 if i < rest else 0)})
        return pd.DataFrame(rows)
    from nsrmp_bench.storage.reader import open as open_data

    path = cast(str, target)
    with open_data(path) as collection:
        frame = collection.index.copy()
    frame["part"] = frame.get("split", path)
    frame["instances"] = 1
    return frame


def _sort_key(value: object) -> tuple[int, float, str]:
    return (0, float(value), "") if isinstance(value, int | float) else (1, 0.0, str(value))


def run(args: argparse.Namespace) -> int:
    """Print a table of counts per value for each category."""
    if (args.target is None) == (args.spec is None):
        msg = ("give what to count: a data directory, a split id or a spec file as TARGET, "
               "or --spec PATH (not both)")
        raise InvalidArgument(msg)
    target = str(args.spec) if args.spec is not None else args.target
    spec = None
    if args.spec is None and Path(target).name == MANIFEST_NAME and Path(target).is_file():
        target = str(Path(target).parent)  # a part's manifest: count that part's data
    if args.spec is not None or (target.endswith(".json") and Path(target).is_file()):
        spec = load_split_file(target)
    frame = category_frame(spec if spec is not None else target)
    console = Console()
    unofficial = "" if spec is None or spec.shipped else f" (unofficial split {spec.id})"
    console.print(f"{target}: {counted(int(frame['instances'].sum()), 'instance')}{unofficial}")
    for part, sub in frame.groupby("part", sort=True):
        table = Table(title=f"{part} ({int(sub['instances'].sum())})")
        table.add_column("category")
        table.add_column("value")
        table.add_column("count", justify="right")
        for col in sub.columns:
            if col in ("part", "split", "id", "index", "shard", "hash", "instances"):
                continue
            counts = sub.groupby(col, dropna=True)["instances"].sum()
            counts = counts[counts > 0]
            counts = counts.sort_index(key=lambda idx: idx.map(_sort_key))
            if col == "template" and len(counts) > 12:
                counts = counts.sort_values(ascending=False).head(12)
            for n, (value, count) in enumerate(counts.items()):
                table.add_row(col if n == 0 else "", str(value), str(count))
        console.print(table)
    return 0
