"""Write a v3 or v4 checkpoint: the networks and vocabulary of the version before with the
reading's settings (``nsrm-v2`` -> ``nsrm-v3``, ``nmn-v2`` -> ``nmn-v3``; ``nsrm-v3`` ->
``nsrm-v4``, ``nmn-v3`` -> ``nmn-v4``: the reader of sentence structure's settings, config
fields too).

    python scripts/reading_checkpoint.py nsrm-v4 --out reference_model/checkpoints/nsrm-v4.pt
    python scripts/reading_checkpoint.py nsrm-v3 [--from PATH] [--set KEY=VALUE ...]
        [--selection DIR/robustness.json] [--size-prior-from data/paper-v2/val]
        --out reference_model/checkpoints/nsrm-v3.pt

The networks are not retrained: the v3 models are their v2 networks behind the front end
(``reference_model/language``), whose settings are config fields (``--set``, e.g.
``synonyms=true``). ``--size-prior-from PART`` fits the perception's size prior
(``reference_model/program/size_calibration.py``) on that part's initial boxes and depths,
without labels, into the config's ``size_prior``. Without ``--from`` the shipped v2
checkpoint, card and log are read.
Beside the checkpoint it writes the card (``<id>.card.json``: the v2 card with the v3
config) and the log (``<id>.log.jsonl``: the v2 networks' training log, then one
``selection`` line per kind of the development suite given with ``--selection``, the table
``nsrmp-bench robustness MODEL --data data/paper-v2/val --words dev --seed 1001`` wrote).
The same input writes the same bytes.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

from nsrmp_bench.reference_model.checkpoints import (
    load_checkpoint,
    save_checkpoint,
    shipped_checkpoint,
)
from nsrmp_bench.reference_model.registry import get_model

SOURCES = {"nsrm-v3": "nsrm-v2", "nmn-v3": "nmn-v2", "nsrm-v4": "nsrm-v3", "nmn-v4": "nmn-v3"}


def size_prior(part: Path, vocab: list[str]) -> tuple[float, ...]:
    """The size prior fitted on ``part``'s objects (inputs only: boxes, depth, camera; the
    estimated sizes do not depend on the action rule)."""
    from nsrmp_bench.reference_model.program.data import program_data, read_items
    from nsrmp_bench.reference_model.program.scene3d import ActionRule
    from nsrmp_bench.reference_model.program.size_calibration import fit_size_prior, part_sizes
    from nsrmp_bench.reference_model.tokens import Vocabulary

    items, _ = read_items(part)
    data = program_data(items, Vocabulary(tuple(vocab)), ActionRule())
    return tuple(float(v) for v in fit_size_prior(part_sizes(data.states)).values())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", choices=sorted(SOURCES))
    parser.add_argument("--from", dest="source", type=Path, default=None)
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE")
    parser.add_argument("--selection", type=Path, default=None,
                        help="the development suite's robustness.json (selection lines)")
    parser.add_argument("--size-prior-from", type=Path, default=None,
                        help="a part whose objects' estimated sizes the size prior is fitted on")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    source_id = SOURCES[args.model]
    payload = load_checkpoint(args.source or shipped_checkpoint(source_id), source_id)
    config_cls = get_model(args.model).config_cls()
    config = config_cls.from_dict(payload["config"]).with_overrides(args.set, args.model)
    if args.size_prior_from is not None:
        config = dataclasses.replace(config, size_prior=size_prior(
            args.size_prior_from, list(payload["vocab"])))
    extra = {**payload.get("extra", {}), "networks_of": source_id}
    save_checkpoint(args.out, args.model, config.to_dict(), list(payload["vocab"]),
                    payload["state"], extra)
    shipped = shipped_checkpoint(source_id).parent
    card = json.loads((shipped / f"{source_id}.card.json").read_text("utf-8"))
    card.update(model=args.model, config=config.to_dict(), networks_of=source_id,
                front_end="the language front end (reference_model/language) with the "
                "config's settings, selected on paper-v2/val perturbed with the development "
                "word lists (seed 1001)")
    if args.model.endswith("-v4"):
        card["reader"] = (
            "the reader of sentence structure (reference_model/language/structure.py, "
            "reading4.py) on the committed lexicon, before the v3 front end; its settings "
            "(phrase_fit, phrase_twice, extreme_members) selected on semantics-v1/train with "
            "paper-v2/val's abstentions held at 2% or less; the networks are not retrained")
    if args.size_prior_from is not None:
        card["size_calibration"] = (
            f"the perception's size prior fitted without labels on {args.size_prior_from.name} "
            f"of {args.size_prior_from.parent.name} (initial boxes and depths); a scene is "
            f"rescaled only {config.scale_evidence} nats more likely than as it is, the "
            f"threshold chosen on paper-v2/val and a development part of the original "
            f"generator (import-original --seed 7)")
    stem = args.out.with_suffix("")
    stem.with_suffix(".card.json").write_text(json.dumps(card, indent=1, sort_keys=True) + "\n")
    log = (shipped / f"{source_id}.log.jsonl").read_text("utf-8")
    if args.selection is not None:
        table = json.loads(args.selection.read_text("utf-8"))
        rows = [r for r in table["rows"] if r["source"] == args.model]
        log += "".join(json.dumps({
            "stage": "selection", "part": f"{table['split']} (development word lists, seed "
            f"{table['seed']})", "kind": r["kind"], "val_iou_m": r["iou_m"],
            "paired_diff": r["diff"], "diff_low": r["diff_low"], "diff_high": r["diff_high"],
        }) + "\n" for r in rows)
    stem.with_suffix(".log.jsonl").write_text(log)
    print(f"{args.model}: wrote {args.out}, its card and log (networks of {source_id})")


if __name__ == "__main__":
    main()
