"""``nsrmp-bench train``: train a learned reference model on a split.

Example::

    nsrmp-bench train nsrm --data data/paper --out runs/nsrm --seed 0

Trains on ``DATA/train``, selects on ``DATA/val``, shows a progress bar per curriculum stage
(loss, validation IoU-M, time left) and writes into ``--out``: ``best.pt`` (the selected
checkpoint), ``last.pt`` (to resume from: rerunning the same command continues an
interrupted run), ``config.json``, ``log.jsonl`` (one line per epoch) and ``card.json``
(the model card). ``--set key=value`` overrides a config field (e.g. for a short run).
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

from nsrmp_bench.errors import InvalidArgument

if TYPE_CHECKING:
    from nsrmp_bench.reference_model.registry import ModelEntry

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("model", help="model name or id (nsrm, nsrm-v1)")
    parser.add_argument("--data", required=True, type=Path,
                        help="split root holding train/ and val/ (e.g. data/paper)")
    parser.add_argument("--out", required=True, type=Path, help="run directory to write")
    parser.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a config field (repeatable), e.g. epochs_attribute=2")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _config(entry: ModelEntry, overrides: list[str]) -> Any:
    entry_id = entry.id
    cfg = entry.config_cls()()
    fields = {f.name: f for f in dataclasses.fields(cfg)}
    changes: dict[str, Any] = {}
    for item in overrides:
        key, sep, value = item.partition("=")
        if not sep or key not in fields:
            msg = (f"--set {item!r} is not KEY=VALUE with a field of {entry_id}'s config; "
                   f"fields: {', '.join(fields)}")
            raise InvalidArgument(msg)
        kind = type(getattr(cfg, key))
        try:
            changes[key] = kind(value)
        except ValueError as exc:
            msg = f"--set {item!r}: {value!r} is not a {kind.__name__}"
            raise InvalidArgument(msg) from exc
    return dataclasses.replace(cfg, **changes)


def run(args: argparse.Namespace) -> int:
    """Train and report where the checkpoint is."""
    from nsrmp_bench.reference_model import registry

    entry = registry.get_model(args.model)
    if args.seed < 0:
        msg = f"--seed must be a non-negative integer, got {args.seed}"
        raise InvalidArgument(msg)
    cfg = _config(entry, args.set)
    best = entry.train_fn()(args.data, args.out, seed=args.seed, config=cfg, quiet=args.quiet)
    name = entry.id.rsplit("-v", 1)[0]
    if entry.id.startswith("detector-"):  # a detector writes detections, not predictions
        use = (f"nsrmp-bench detect --data {args.data / 'test'} --out D.jsonl "
               f"--checkpoint {best}")
    elif hasattr(entry.predictor_cls(), "predict"):
        use = (f"nsrmp-bench predict {name} --data {args.data / 'test'} --out P.jsonl "
               f"--checkpoint {best}")
    else:  # an image model (reconstruction): it runs over a predictions file
        use = (f"nsrmp-bench reconstruct P.jsonl --data {args.data / 'test'} --out DIR "
               f"--checkpoint {best}")
    print(f"{entry.id}: best checkpoint {best}; use it with: {use}")
    return 0
