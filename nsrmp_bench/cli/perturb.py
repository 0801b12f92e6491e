"""``nsrmp-bench perturb DATA --kind KIND --seed S --out OUT``: a perturbed copy of a part.

Example::

    nsrmp-bench perturb data/paper-v2/test --kind typo --seed 0 --out data/robust/typo
    nsrmp-bench score nsrm.jsonl --data data/robust/typo

The copy has the same episodes, ids and gold, and other instruction texts; the
manifest records the kind and seed, ``perturbations.jsonl`` what changed in each instance.
Kinds: polite, filler, typo, synonym, reorder, case, and the controls blind and shuffled
(``docs/robustness.md``). The same seed writes the same bytes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.cli.numbers import non_negative_int
from nsrmp_bench.plurals import counted
from nsrmp_bench.robustness.kinds import KINDS
from nsrmp_bench.storage.atomic import output_dir

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("data", type=Path, help="the part to perturb (e.g. data/paper-v2/test)")
    parser.add_argument("--kind", required=True, choices=KINDS,
                        help="what to change: " + ", ".join(KINDS))
    parser.add_argument("--seed", required=True, type=non_negative_int,
                        help="seed of the perturbation (the suite's test seed is 0)")
    parser.add_argument("--out", required=True, type=output_dir,
                        help="folder of the perturbed part (new or empty)")
    parser.add_argument("--words", choices=("test", "dev"), default="test",
                        help="word lists: test (the suite's, default) or dev (other words "
                        "for the same kinds: for augmentation and selecting a model)")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def run(args: argparse.Namespace) -> int:
    """Write the perturbed part and say how many instances changed."""
    from nsrmp_bench.cli.progress import episode_progress
    from nsrmp_bench.robustness.part import perturb_part
    from nsrmp_bench.storage.manifest import read_manifest

    total = read_manifest(args.data).count
    with episode_progress(disable=args.quiet) as bar:
        task = bar.add_task(f"perturb {args.kind}", total=total)
        report = perturb_part(args.data, args.out, kind=args.kind, seed=args.seed,
                              words=args.words,
                              progress=lambda n: bar.update(task, completed=n))
    if not args.quiet:
        print(f"{args.kind} (seed {args.seed}): wrote {args.out}; "
              f"{counted(report.changed, 'instruction')} changed, {report.unchanged} "
              f"unchanged (perturbations.jsonl says why), root hash "
              f"{report.manifest.root_hash}")
    return 0
