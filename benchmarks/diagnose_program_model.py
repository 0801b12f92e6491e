"""The oracle ladder of a program model, through the public scorer.

    python benchmarks/diagnose_program_model.py --model nsrm-v2 --data DATA/paper-v2/test \
        [--checkpoint best.pt] [--out DIR]

Each rung replaces one more part of the model by the gold answer and scores the
predictions file it writes with ``nsrmp-bench score``: the model as is; + gold split
(the steps cut where the instruction's steps meet); + gold action; + gold grounding
(each step's subject and base); the last rung is then the gold program run through the
model's action rule (a simulator check). It prints IoU-M (with single-step and
multi-step IoU-M), program exact and subject (all steps), as the diagnosis does
(``shared/reference/nsrm-v1-diagnosis.md``). Works for any program model on the shared
parts (``nsrm-v2``, ``nmn-v2``).

The gold parts are read from the episodes' targets (program, lexed instruction) and the
connectors of the templates; the model never sees them: this is measurement only.
"""

from __future__ import annotations

import argparse
import json
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nsrmp_bench.cli.main import main as cli
from nsrmp_bench.reference_model.program.data import read_items
from nsrmp_bench.reference_model.program.inference import Oracle
from nsrmp_bench.reference_model.program.run import ProgramModelBase
from nsrmp_bench.reference_model.registry import load_model
from nsrmp_bench.reference_model.tokens import tokenise
from nsrmp_bench.storage.split_root import resolve_part

PLACEHOLDER = re.compile(r"<([SR])(\d+)>")


def connectors() -> list[str]:
    from importlib import resources

    syn = json.loads(resources.files("nsrmp_bench.generators").joinpath(
        "templates", "synonyms.json").read_text("utf-8"))
    words = [*syn["connectors"]["values"], *syn["connectors"]["held_out"],
             *syn["final_connectors"]["values"], *syn["final_connectors"]["held_out"]]
    return sorted(words, key=len, reverse=True)


def match_lexed(text: str, lexed: str) -> tuple[list[re.Match[str]], re.Match[str] | None]:
    """The lexed instruction's reference placeholders, and the instruction matched against
    it with one group per placeholder (None where the text does not follow it)."""
    marks = list(PLACEHOLDER.finditer(lexed))
    pattern, pos = "", 0
    for m in marks:
        pattern += re.escape(lexed[pos : m.start()]) + "(.+?)"
        pos = m.end()
    pattern += re.escape(lexed[pos:]) + "$"
    return marks, re.match(pattern, text, flags=re.IGNORECASE | re.DOTALL)


def gold_cuts(text: str, lexed: str, steps: int, connectors: list[str]) -> list[int]:
    """Token positions where steps 2.. start: at the connector between step k-1's last
    reference and step k's first."""
    marks, found = match_lexed(text, lexed)
    if found is None:
        return []
    cuts = []
    for k in range(2, steps + 1):
        before = [i for i, m in enumerate(marks) if int(m.group(2)) == k - 1]
        after = [i for i, m in enumerate(marks) if int(m.group(2)) == k]
        if not before or not after:
            continue
        lo, hi = marks[max(before)].end(), marks[min(after)].start()
        region = lexed[lo:hi]
        hits = [(region.lower().find(c.lower()), -len(c)) for c in connectors
                if region.lower().find(c.lower()) >= 0]
        if not hits:
            continue
        # the text between the two references is the lexed region itself
        text_at = found.end(max(before) + 1) + min(hits)[0]
        cuts.append(len(tokenise(text[:text_at])))
    return cuts


@dataclass(frozen=True)
class GoldParts:
    """Per episode, read from its targets and symbolic record (measurement only): the gold
    cuts, actions, (subject, base) per step, the steps (action, subject, base) and the
    symbolic record."""

    cuts: list[list[int]]
    actions: list[list[int]]
    grounding: list[list[tuple[int, int]]]
    steps: list[list[tuple[int, int, int]]]
    symbolic: list[Any]


def gold_parts(items: list[dict[str, Any]], ds: Any) -> GoldParts:
    """The gold parts of ``items`` (``read_items``'s dataset ``ds`` holds their records)."""
    words = connectors()
    out = GoldParts([], [], [], [], [])
    for i, it in enumerate(items):
        steps = [(int(a), int(s), int(r)) for a, s, r in it["targets"]["grounded"].tolist()]
        sym = ds.collection.episode(i, images=False).symbolic
        out.steps.append(steps)
        out.actions.append([a for a, _, _ in steps])
        out.grounding.append([(s, r) for _, s, r in steps])
        out.cuts.append(gold_cuts(str(it["inputs"]["instruction"]), sym.instruction.lexed,
                                  len(steps), words))
        out.symbolic.append(sym)
    return out


def program_model_args(description: str, examples: int | None = None,
                       ) -> tuple[argparse.Namespace, ProgramModelBase]:
    """The measurement scripts' command line (``--model``, ``--data``, ``--checkpoint``
    and, where ``examples`` is given, ``--examples`` with that default), parsed, and the
    program model it names, loaded (any other model is refused)."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--model", default="nsrm-v2")
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--checkpoint", type=Path)
    if examples is not None:
        ap.add_argument("--examples", type=int, default=examples,
                        help="misses to print (per group where the script groups them)")
    args = ap.parse_args()
    model = load_model(args.model, args.checkpoint)
    if not isinstance(model, ProgramModelBase):
        msg = f"{args.model} is not a program model (nsrm-v2, nmn-v2)"
        raise SystemExit(msg)
    return args, model


def _score(pred: Path, data: Path, tmp: Path) -> dict[str, Any]:
    out = tmp / (pred.stem + ".json")
    cli(["score", str(pred), "--data", str(data), "--json", str(out), "--quiet",
         "--n-boot", "0"])
    return dict(json.loads(out.read_text("utf-8")))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="nsrm-v2")
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--checkpoint", type=Path)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    from nsrmp_bench.reference_model.predictions import write_model_predictions

    part = resolve_part(args.data)
    model = load_model(args.model, args.checkpoint)
    items, ds = read_items(part)
    split = ds.collection.split
    gold = gold_parts(items, ds)
    cuts, actions, grounding = gold.cuts, gold.actions, gold.grounding
    rungs = [
        ("model as is", Oracle()),
        ("+ gold split", Oracle(cuts=cuts)),
        ("+ gold action", Oracle(cuts=cuts, actions=actions)),
        ("+ gold grounding (= gold program, model's action rule)",
         Oracle(cuts=cuts, actions=actions, grounding=grounding)),
    ]
    out_dir = args.out or Path(tempfile.mkdtemp(prefix="ladder-"))
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for i, (name, oracle) in enumerate(rungs):
        pred = out_dir / f"rung{i}.jsonl"
        write_model_predictions(pred, split, model.model_id,
                                model.predict(items, oracle), {"rung": name})
        s = _score(pred, part, out_dir)
        summ = s["summary"]
        rows.append((name, summ["iou_m"]["value"], summ["program_exact"]["value"],
                     summ["subject_all_steps"]["value"], summ["success_3d"]["value"]))
    print(f"oracle ladder of {model.model_id} on {split} ({len(items)} episodes), public scorer")
    print("| # | rung | IoU-M | program exact | subject (all steps) | success 3D |")
    print("|---|---|---|---|---|---|")
    for i, (name, iou, prog, subj, s3d) in enumerate(rows):
        print(f"| {i} | {name} | {iou:.3f} | {prog:.3f} | {subj:.3f} | {s3d:.3f} |")
    print(f"files: {out_dir}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
