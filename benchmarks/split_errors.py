"""Where a program model's splitter cuts an instruction wrong (measurement only).

    python benchmarks/split_errors.py --model nsrm-v2 --data DATA/paper-v2/test \
        [--checkpoint best.pt] [--examples 10]

Compares the splitter's cuts (token positions where steps 2.. start) with the cuts at the
templates' connectors (``diagnose_program_model.gold_cuts``, read from the episodes'
targets; the model never sees them) and counts the instructions cut into too many steps,
too few, or as many but more than two tokens away from a connector (inside a reference).
A cut one or two tokens off (before or after a comma or "after that") reads the same
steps and is counted right. Each printed miss shows the instruction with ``|k`` after
token ``k`` where either cut falls, and the splitter's three largest peaks.
"""

from __future__ import annotations

from collections import Counter

import torch
from diagnose_program_model import gold_parts, program_model_args

from nsrmp_bench.reference_model.program.data import program_data, read_items
from nsrmp_bench.reference_model.program.modules import pad_tokens

NEAR = 2
"""Tokens a cut may be from the connector and still read the same steps."""


def kind(pred: list[int], gold: list[int]) -> str:
    """How ``pred`` misses ``gold``: "right", "over-cut", "under-cut" or "misplaced"."""
    if len(pred) > len(gold):
        return "over-cut"
    if len(pred) < len(gold):
        return "under-cut"
    if any(abs(a - b) > NEAR for a, b in zip(pred, gold, strict=True)):
        return "misplaced"
    return "right"


def main() -> int:
    args, model = program_model_args(__doc__.splitlines()[0], examples=10)
    items, ds = read_items(args.data)
    gold = gold_parts(items, ds)
    data = program_data(items, model.vocab, model.rule)
    splitter = model.model.splitter.eval()
    words = model.vocab.to_list()
    with torch.no_grad():
        cuts = splitter.cuts(data.tokens)
        probs = torch.sigmoid(splitter(pad_tokens(data.tokens)))
    counts: Counter[str] = Counter()
    shown = 0
    for i, (pred, want) in enumerate(zip(cuts, gold.cuts, strict=True)):
        if len(want) != len(gold.steps[i]) - 1:
            counts["connector not found"] += 1
            continue
        k = kind(pred, want)
        counts[k] += 1
        if k != "right" and shown < args.examples:
            shown += 1
            tok = data.tokens[i]
            marks = set(pred) | set(want)
            text = " ".join(f"{words[t]}|{j + 1}" if j + 1 in marks else words[t]
                            for j, t in enumerate(tok))
            peaks = [(t, round(m, 2)) for t, m in splitter.peaks(probs[i, : len(tok)])[:3]]
            print(f"{items[i]['id']} {k}: connectors {want}, cuts {pred}, peaks {peaks}")
            print(f"    {text}")
    print(f"splitter of {model.model_id} on {args.data} ({len(items)} instructions; gap "
          f"{splitter.gap}, threshold {float(splitter.threshold):.2f}):")
    for name in ("right", "over-cut", "under-cut", "misplaced", "connector not found"):
        print(f"  {name}: {counts[name]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
