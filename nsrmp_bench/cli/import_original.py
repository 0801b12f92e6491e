"""``nsrmp-bench import-original TREE --out DATA``: a TEST part made by the original
authors' generator.

    nsrmp-bench import-original /tmp/nsrmp-original --out data/original-v1/test \\
        --examples 300 --seed 0 --size 320x240

TREE is the root of ``dair-iitd/nsrmp`` at ``bf6ba54`` (checked file by file). Its
``construct.py`` runs unchanged through the headless shim, once per template file and
language, object counts cycling over ``--objects``; the examples are imported with the
``import-nsrm`` importer and the manifest pins what was run. Needs the ``sim`` extra.
The part is for reporting only: nothing trains or selects on it.
"""

from __future__ import annotations

import argparse

from nsrmp_bench.cli.numbers import non_negative_int, positive_int
from nsrmp_bench.plurals import counted
from nsrmp_bench.storage.atomic import output_dir


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        w = h = 0
    if w < 1 or h < 1:
        msg = f"expected WIDTHxHEIGHT, e.g. 320x240 or 1024x768, got {text!r}"
        raise argparse.ArgumentTypeError(msg)
    return w, h


def _names(text: str) -> tuple[str, ...]:
    return tuple(v.strip() for v in text.split(",") if v.strip())


def _counts(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(","))
    except ValueError:
        msg = f"expected object counts separated by commas, e.g. 3,4,5, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    from nsrmp_bench.generators.original.part import DEFAULT_OBJECTS, DEFAULT_TEMPLATES
    from nsrmp_bench.generators.original.run import DEFAULT_SIZE

    parser.add_argument("tree", metavar="TREE",
                        help="root of dair-iitd/nsrmp at bf6ba54 (the folder holding "
                        "data_generation/)")
    parser.add_argument("--out", required=True, type=output_dir,
                        help="the part's folder (new or empty), e.g. data/original-v1/test")
    parser.add_argument("--examples", type=positive_int, default=300,
                        help="examples in the part (default 300)")
    parser.add_argument("--seed", type=non_negative_int, default=0,
                        help="seeds every run of the original (default 0)")
    parser.add_argument("--templates", type=_names, default=DEFAULT_TEMPLATES,
                        help="template files of the original, comma-separated (default: all "
                        "five)")
    parser.add_argument("--objects", type=_counts, default=DEFAULT_OBJECTS,
                        help="object counts the runs cycle over (default 3,4,5)")
    parser.add_argument("--size", type=_size, default=DEFAULT_SIZE,
                        help="image size WIDTHxHEIGHT (default the original's 1024x768; "
                        "320x240 is ours and ~10x faster)")
    parser.add_argument("--split", default="original-v1/test", help="split name to record")
    parser.add_argument("--shard-size", type=positive_int, default=1000,
                        help="episodes per shard")
    parser.add_argument("--work", default=None,
                        help="keep the original's own folders here (a new folder); default: "
                        "a temporary folder, removed")


def run(args: argparse.Namespace) -> int:
    """Run the original, import, print a summary."""
    from nsrmp_bench.generators.original.part import PlannedRun, make_original_part
    from nsrmp_bench.generators.original.run import OriginalRun

    def progress(planned: PlannedRun, run: OriginalRun) -> None:
        print(f"  {planned.name}: seed {run.spec.seed}, {run.spec.scenes} "
              f"scenes -> {counted(len(run.samples), 'example')} in {run.wall_s:.1f} s "
              f"({'/'.join(run.languages) or '-'}; {run.no_program} x no program)", flush=True)

    report = make_original_part(
        args.tree, args.out, examples=args.examples, seed=args.seed, templates=args.templates,
        objects=args.objects, size=args.size, split=args.split, shard_size=args.shard_size,
        work=args.work, progress=progress)
    m = report.imported.manifest
    print(f"imported {report.imported.imported} examples of the original generator into "
          f"{args.out}: {counted(len(m.shards), 'shard')}, root hash {m.root_hash}; a TEST "
          "part: nothing trains or selects on it")
    return 0
