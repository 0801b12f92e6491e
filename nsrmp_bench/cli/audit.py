"""``nsrmp-bench audit [DATA ...]``: what the splits share, and where held-out material is.

Examples::

    nsrmp-bench audit                         # regenerate every shipped split symbolically
    nsrmp-bench audit data/paper data/attributes   # audit generated data

Exits 1 if any seed, id, scene or (scene, program, instruction) triple is shared across
parts, or held-out combinations / language appear where they must not.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from pathlib import Path

from rich.console import Console
from rich.table import Table

from nsrmp_bench.audit import audit, held_out_words
from nsrmp_bench.episode import SymbolicEpisode
from nsrmp_bench.split_specs import list_splits, load_split

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("data", nargs="*", type=Path,
                        help="split or part directories; none: regenerate every shipped "
                        "split (the official set and training material such as dense5x-v2) "
                        "symbolically from its spec")
    parser.add_argument("--splits", nargs="+", default=None,
                        help="split ids for the symbolic audit (default: every shipped split)")


def _from_specs(split_ids: list[str]) -> Iterator[tuple[str, str, SymbolicEpisode]]:
    from nsrmp_bench.generators import sampler

    for sid in split_ids:
        spec = load_split(sid)
        for part, ps in spec.parts.items():
            if ps.entropy is None:  # a private part: only its data can be audited
                continue
            for i in range(ps.count):
                ep = sampler.sample_episode(spec.config(part, i), ps.entropy, i,
                                            spec.episode_id(part, i))
                yield sid, part, ep


def _from_data(paths: list[Path]) -> Iterator[tuple[str, str, SymbolicEpisode]]:
    from nsrmp_bench.storage.reader import open as open_data
    from nsrmp_bench.storage.split_root import split_root_parts

    dirs: list[Path] = []
    for p in paths:
        if (p / "manifest.json").is_file() or p.is_file():
            dirs.append(p)
        else:
            dirs.extend(p / q for q in split_root_parts(p))
    for d in dirs:
        with open_data(d) as collection:
            for ep in collection.iter_episodes(images=False):
                split = str(collection.index["split"].iloc[0])
                sid, _, part = split.partition("/")
                yield sid, part, ep.symbolic


def run(args: argparse.Namespace) -> int:
    """Print the measured numbers; exit 1 if a guarantee fails."""
    if args.data:
        source = _from_data(args.data)
        what = "generated data"
    else:
        ids = args.splits or list(list_splits())
        for sid in ids:
            load_split(sid)
        source = _from_specs(ids)
        what = "symbolic regeneration of " + ", ".join(ids)
    from nsrmp_bench.generators.templates import load_language

    report = audit(source, held_out_words(load_language()))
    table = Table(title=f"audit ({what})")
    for col in ("section", "measure", "value"):
        table.add_column(col, justify="right" if col == "value" else "left")
    for row in report.rows():
        table.add_row(*row)
    console = Console()
    console.print(table)
    if report.ok:
        console.print("[green]audit passed[/green]: nothing shared across parts, held-out "
                      "material only where allowed")
        return 0
    for failure in report.failures:
        console.print(f"[red]FAIL[/red] {failure}")
    return 1
