"""``nsrmp-bench train``: train a learned reference model on a split.

Example::

    nsrmp-bench train nsrm --data data/paper --out runs/nsrm --seed 0

Trains on ``DATA/train``, selects on ``DATA/val``, shows a progress bar per curriculum stage
(loss, validation IoU-M, time left) and writes into ``--out``: ``best.pt`` (the selected
checkpoint), ``last.pt`` (to resume from: rerunning the same command continues an
interrupted run), ``config.json``, ``log.jsonl`` (one line per epoch) and ``card.json``
(the model card). ``--set key=value`` overrides a config field (e.g. for a short run),
parsed by the field's type. Rerunning into the same ``--out`` resumes; with another config
it is refused before anything is written (``--out`` elsewhere, or ``--restart``).
A program model of several ``members`` (``nsrm-v2``, ``nmn-v2``: three by default) trains
each member as a run of its own in ``--out/member-K``, in parallel (one process each, with
the members' progress in their logs), then writes the run's files for the members read as
one.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from nsrmp_bench.errors import InvalidArgument

__all__ = ["add_arguments", "run", "test_part"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("model", help="model name or id (nsrm, nsrm-v2)")
    parser.add_argument("--data", required=True, type=Path,
                        help="split root holding train/ and val/ (e.g. data/paper)")
    parser.add_argument("--out", required=True, type=Path, help="run directory to write")
    parser.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a config field (repeatable), parsed by the field's "
                        "type, e.g. epochs_attribute=2, lr=1e-3, flag=false, limit=none")
    parser.add_argument("--restart", action="store_true",
                        help="start the run in --out over (deletes its checkpoints, log and "
                        "card) instead of resuming it")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    """Train and report where the checkpoint is."""
    from nsrmp_bench._optional import require
    from nsrmp_bench.reference_model import registry

    entry = registry.get_model(args.model)
    if args.seed < 0:
        msg = f"--seed must be a non-negative integer, got {args.seed}"
        raise InvalidArgument(msg)
    require("torch")
    model = entry.model_cls()
    cfg = model.config_cls().with_overrides(args.set, entry.id)
    best = model.train(args.data, args.out, seed=args.seed, config=cfg, quiet=args.quiet,
                       restart=args.restart)
    use = entry.kind.use_after_training(entry.name, str(test_part(args.data, cfg)), str(best))
    print(f"{entry.id}: best checkpoint {best}; use it with: {use}")
    return 0


def test_part(data: Path, config: object) -> Path:
    """The part a freshly trained model is scored on: ``DATA/test``; for training material
    without a test part that selects on a part beside it (dense5x-v2 selects on
    ``../paper-v2/val``), the test part beside that one."""
    test = data / "test"
    val = getattr(config, "val", None)
    if test.exists() or not isinstance(val, str):
        return test
    return Path(os.path.normpath(data / val)).parent / "test"
