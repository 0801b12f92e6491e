"""Where a program model's grounding goes wrong, by reference kind (measurement only).

    python benchmarks/grounding_errors.py --model nsrm-v2 --data DATA/paper-v2/val \
        [--checkpoint best.pt] [--examples 5]

The model runs with the gold split and the gold action (the ladder's rung 2, see
``diagnose_program_model.py``), so every miss counted here is grounding. Each step's
subject and base are counted by step (first, later) and by the kind of reference the
instruction used: ``attr`` (attributes only), ``rel`` (related to an anchor) or ``it``
(the instruction says "it", "that" or "that one"; the program names the object its own
way). A miss is also said as what was confused: the colour, the shape, both, or neither
(another object with the same attributes: the relation chose wrong). The gold program,
the lexed instruction and the scene's attributes are read from the episodes' targets and
symbolic records: the model never sees them.
"""

from __future__ import annotations

from collections import Counter, defaultdict
from typing import Any

from diagnose_program_model import gold_parts, match_lexed, program_model_args

from nsrmp_bench.reference_model.program.data import read_items
from nsrmp_bench.reference_model.program.inference import Oracle

PRONOUNS = ("it", "that", "that one")


def reference_spans(text: str, lexed: str) -> dict[tuple[str, int], str]:
    """The text of each reference placeholder (``("S", 1)``: step 1's subject)."""
    marks, found = match_lexed(text, lexed)
    if found is None:
        return {}
    return {(m.group(1), int(m.group(2))): found.group(j + 1) for j, m in enumerate(marks)}


def reference_kinds(symbolic: Any) -> list[tuple[str, str]]:
    """(subject kind, base kind) of each step of an episode's program."""
    nodes = symbolic.program.nodes

    def related(k: int) -> bool:
        while True:
            if nodes[k].op == "relate":
                return True
            if not nodes[k].inputs:
                return False
            k = nodes[k].inputs[0]

    spans = reference_spans(symbolic.instruction.text, symbolic.instruction.lexed)
    out = []
    for step, node in enumerate((n for n in nodes if n.op == "move"), start=1):
        kinds = []
        for role, k in (("S", node.inputs[1]), ("R", node.inputs[2])):
            said = spans.get((role, step), "").strip().lower()
            kinds.append("it" if said in PRONOUNS else "rel" if related(k) else "attr")
        out.append((kinds[0], kinds[1]))
    return out


def main() -> int:
    args, model = program_model_args(__doc__.splitlines()[0], examples=0)
    items, ds = read_items(args.data)
    parts = gold_parts(items, ds)
    gold = parts.steps
    kinds = [reference_kinds(sym) for sym in parts.symbolic]
    attrs = [[(o.colour, o.shape) for o in sym.scene.objects] for sym in parts.symbolic]
    decoded = model.programs(items, Oracle(cuts=parts.cuts, actions=parts.actions))
    right: Counter[tuple[str, str, str]] = Counter()
    total: Counter[tuple[str, str, str]] = Counter()
    confused: Counter[tuple[str, str]] = Counter()
    examples: dict[tuple[str, str, str], list[str]] = defaultdict(list)
    for i, (steps, want, kind) in enumerate(zip(decoded, gold, kinds, strict=True)):
        for k, (w, kd) in enumerate(zip(want, kind, strict=False)):
            got = steps[k] if k < len(steps) else (-1, -1, -1)
            for role, idx, rk in (("subject", 1, kd[0]), ("base", 2, kd[1])):
                key = (role, "first" if k == 0 else "later", rk)
                total[key] += 1
                if got[idx] == w[idx]:
                    right[key] += 1
                    continue
                a, b = attrs[i][w[idx]], attrs[i][got[idx]] if got[idx] >= 0 else ("", "")
                what = ("neither" if a == b else "colour" if a[1] == b[1] else
                        "shape" if a[0] == b[0] else "both")
                confused[(rk, what)] += 1
                if len(examples[key]) < args.examples:
                    examples[key].append(f"{items[i]['id']}: {items[i]['inputs']['instruction']}"
                                         f"  (wanted {a}, chose {b})")
    print(f"grounding of {model.model_id} on {args.data} with gold split and action")
    print("| role | step | reference | right |")
    print("|---|---|---|---|")
    for key in sorted(total):
        print(f"| {key[0]} | {key[1]} | {key[2]} | {right[key]}/{total[key]} = "
              f"{right[key] / total[key]:.3f} |")
    print("misses by what was confused:",
          ", ".join(f"{k} {w}: {n}" for (k, w), n in sorted(confused.items())))
    for key, lines in sorted(examples.items()):
        if not lines:
            continue
        print(f"-- {' '.join(key)}")
        for line in lines:
            print("  ", line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
