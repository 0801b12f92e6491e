"""``nsrmp-bench info DATA|SPLIT``: counts per category, as tables.

Examples::

    nsrmp-bench info data/paper/test      # what was generated
    nsrmp-bench info paper-v2             # what the spec asks for, per part
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
from rich.console import Console
from rich.table import Table

from nsrmp_bench.split_specs import SPLIT_ID_RE, load_split

__all__ = ["add_arguments", "category_frame", "run"]

CATEGORIES = ("steps", "objects", "relational", "relation_needed", "phrasing", "template")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("target", help="a data directory / shard, or a split id like paper-v2")


def category_frame(target: str) -> pd.DataFrame:
    """One row per instance with its categories (and a ``part`` column)."""
    if SPLIT_ID_RE.match(target) and not Path(target).exists():
        spec = load_split(target)
        rows = []
        for part, ps in spec.parts.items():
            for i in range(ps.count):
                c = spec.config(part, i)
                rows.append({"part": part, "steps": c.steps, "objects": c.objects,
                             "relational": c.relational, "phrasing": c.phrasing,
                             "held_out_language": c.held_out,
                             "held_out_pairs_required": bool(c.required_pairs)})
        return pd.DataFrame(rows)
    from nsrmp_bench.storage.reader import open as open_data

    with open_data(target) as collection:
        frame = collection.index.copy()
    frame["part"] = frame.get("split", target)
    return frame


def _sort_key(value: object) -> tuple[int, float, str]:
    return (0, float(value), "") if isinstance(value, int | float) else (1, 0.0, str(value))


def run(args: argparse.Namespace) -> int:
    """Print a table of counts per value for each category."""
    frame = category_frame(args.target)
    console = Console()
    console.print(f"{args.target}: {len(frame)} instances")
    for part, sub in frame.groupby("part", sort=True):
        table = Table(title=f"{part} ({len(sub)})")
        table.add_column("category")
        table.add_column("value")
        table.add_column("count", justify="right")
        for col in sub.columns:
            if col in ("part", "split", "id", "index", "shard", "hash"):
                continue
            counts = sub[col].value_counts()
            counts = counts.sort_index(key=lambda idx: idx.map(_sort_key))
            if col == "template" and len(counts) > 12:
                counts = counts.sort_values(ascending=False).head(12)
            for n, (value, count) in enumerate(counts.items()):
                table.add_row(col if n == 0 else "", str(value), str(count))
        console.print(table)
    return 0
