"""``nsrmp-bench generate``: generate (or resume) a split into HDF5 shards.

Example::

    nsrmp-bench generate --split paper-v2 --out data/paper --workers 2
    nsrmp-bench generate --split paper-v2 --out /shared/paper --engine dask \
        --scheduler tcp://HOST:8786
    nsrmp-bench generate --spec my-split.json --out data/mine   # a custom split

Each part lands in ``OUT/<part>/`` (shards, ``manifest.json``). The bytes do not depend on
``--engine``, ``--workers`` or the order of generation; a rerun after Ctrl-C, a kill or a
lost scheduler keeps the shards already complete. The root hash is compared with the
committed manifest in ``splits/``.
A custom split (``--spec PATH``, or ``--split PATH``) is a spec file of the shipped specs'
form (copy ``splits/paper-v2.json``, change the counts, objects, entropy and the id); it
is unofficial: its manifest holds the spec, and there is no committed manifest to compare.
Custom specs run on every engine: each shard task carries the spec itself.
A private part (``"entropy": "secret"`` in its spec) needs its secret: ``--secret-file
PATH`` or the environment variable ``NSRMP_BENCH_SECRET``; it is never written, and the
manifest holds a commitment to it (``docs/challenge.md``).
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from rich.console import Console

from nsrmp_bench.cli.engine_options import add_engine_arguments, engine_from_args
from nsrmp_bench.cli.numbers import positive_int
from nsrmp_bench.cli.progress import episode_progress
from nsrmp_bench.official_manifests import official_manifest
from nsrmp_bench.plurals import counted
from nsrmp_bench.private_parts import read_secret
from nsrmp_bench.split_specs import load_split_file, resolve_split
from nsrmp_bench.storage.atomic import output_dir
from nsrmp_bench.verify import compare_with_committed

if TYPE_CHECKING:
    from nsrmp_bench.engine import Engine
    from nsrmp_bench.generators.sampler import AttemptLog
    from nsrmp_bench.split_specs import SplitSpec
    from nsrmp_bench.storage.manifest import Manifest


class _PartGenerator(Protocol):
    """What the command calls of ``nsrmp_bench.generators.generate`` (imported only once
    pybullet is known to be there)."""

    def generate_part(
        self, spec: SplitSpec, part: str, out_dir: str | os.PathLike[str], *,
        engine: Engine | None = ..., shard_size: int = ..., limit: int | None = ...,
        on_progress: Callable[[int], None] | None = ...,
        on_start: Callable[[int, int], None] | None = ..., secret: str | None = ...,
    ) -> tuple[Manifest, AttemptLog]: ...

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--split", help="split id, e.g. paper-v2 (or a spec file's path)")
    which.add_argument("--spec", type=Path, metavar="PATH",
                       help="a custom split spec file (JSON, the form of splits/paper-v2.json)")
    parser.add_argument("--out", required=True, type=output_dir, help="output directory")
    parser.add_argument("--part", action="append", default=None,
                        help="only this part (repeatable); default: every part")
    add_engine_arguments(parser, workers=2)
    parser.add_argument("--shard-size", type=positive_int, default=100,
                        help="instances per shard (default 100)")
    parser.add_argument("--limit", type=positive_int, default=None,
                        help="only the first N instances of each part (not the official split)")
    parser.add_argument("--secret-file", type=Path, default=None, metavar="PATH",
                        help="a private part's secret (default: $NSRMP_BENCH_SECRET); never "
                        "written, the manifest holds a commitment to it")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    """Generate, then print each part's count, time, rate, rejections and root hash."""
    from nsrmp_bench._optional import require

    # the spec first: a bad value is named whatever is installed
    spec = load_split_file(args.spec) if args.spec is not None else resolve_split(args.split)
    parts = args.part or list(spec.parts)
    secret = read_secret(args.secret_file)
    for part in parts:
        ps = spec.part(part)  # unknown part: a clear error before any work
        if ps.private and secret is None:
            raise ps.missing_secret(spec.id)
    require("pybullet")  # before any work, also of pool workers that would import it
    from nsrmp_bench.generators import generate as gen

    console = Console(stderr=True)
    with engine_from_args(args) as engine:
        return max((_generate(gen, spec, part, engine, args, console, secret)
                    for part in parts), default=0)


def _generate(gen: _PartGenerator, spec: SplitSpec, part: str, engine: Engine,
              args: argparse.Namespace, console: Console, secret: str | None) -> int:
    """One part: generate, print the summary, compare with the committed manifest."""
    out = args.out / part
    t0 = time.perf_counter()
    with episode_progress(disable=args.quiet) as progress:
        task = progress.add_task(f"{spec.id}/{part}", total=None)

        def on_start(total: int, done: int) -> None:
            progress.update(task, total=total, completed=done)

        manifest, stats = gen.generate_part(
            spec, part, out, engine=engine, shard_size=args.shard_size,
            limit=args.limit, on_start=on_start,
            on_progress=lambda n: progress.advance(task, n), secret=secret,
        )
    wall = time.perf_counter() - t0
    rate = stats.episodes / wall if stats.episodes else 0.0
    rejected = sum(stats.reasons.values())
    console.print(
        f"{spec.id}/{part}: {counted(manifest.count, 'episode')} in {out} "
        f"({stats.episodes} generated in {wall:.1f} s, {rate:.1f} ep/s; "
        f"{rejected} attempts rejected{_reasons(stats)})"
    )
    console.print(f"  root hash {manifest.root_hash}")
    if manifest.private is not None:
        console.print(f"  private part: commitment {manifest.private['commitment']} (the "
                      "secret is not written anywhere; keep it to reveal later)")
    if not spec.shipped:
        console.print(f"  unofficial split (spec {spec.source}, written into the "
                      "manifest): no committed manifest to compare against")
        return 0
    committed = official_manifest(spec.id, part)
    if committed is None or args.limit is not None:
        return 0
    cmp = compare_with_committed(
        {e.index: (e.hash, e.tolerant) for e in manifest.episodes}, committed)
    if committed["root_hash"] == manifest.root_hash:
        console.print("  matches the committed manifest")
    elif cmp.ok:
        console.print(
            f"  matches the committed manifest: {len(cmp.within_tolerance)} robot "
            "episodes differ in bits but agree within its stated tolerances")
    else:
        console.print(
            "  [red]differs from the committed manifest[/red]: run "
            f"`nsrmp-bench verify {out}` to see which episodes and why"
        )
        return 1
    return 0


def _reasons(stats: AttemptLog) -> str:
    if not stats.reasons:
        return ""
    parts = ", ".join(f"{k} {v}" for k, v in stats.reasons.most_common())
    return f": {parts}"
