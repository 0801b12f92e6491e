"""Figures of a learned model on every official test part: the public scorer's numbers.

Usage::

    .venv/bin/python benchmarks/bench_model.py --data-root data --model nsrm|nmn
        [--checkpoint PATH] [--out results/MODEL] [--run runs/MODEL]

For each test part found under the root (``smoke-v2/test``, ``paper-v2/test``,
``objects-v2/test``, ``steps-v2/test``, ``language-v2/test``, ``attributes-v2/test``) it
runs ``nsrmp-bench predict`` (timed: wall seconds per 1,000 episodes), scores the file
with the public scorer and prints the paper's table (IoU / IoU-M overall, single/double
step, simple/relational; program accuracy; identification/placement on single-step),
IoU-M by object count, step count and held-out kind, with 95% intervals. ``--run`` adds
the training wall time from the run's model card.
A part can use its own checkpoint with ``--part-checkpoint attributes=PATH``. The
predictions files it writes (``OUT/<split>-test.jsonl``) are the ones a leaderboard entry
cites. The two models side by side (the paper's Table I layout, and the figures by
objects and steps) come from ``nsrmp-bench evaluate nsrm nmn`` and ``report`` / ``plot``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

PARTS = ("smoke-v2/test", "paper-v2/test", "objects-v2/test", "steps-v2/test",
         "language-v2/test", "attributes-v2/test")
SUMMARY = ("iou_m", "iou", "success", "program_exact", "action_all_steps", "subject_all_steps",
           "predicate_all_steps", "subject_per_step", "identification", "placement")


def _cli() -> list[str]:
    exe = Path(sys.executable).with_name("nsrmp-bench")
    return [str(exe)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data-root", type=Path, required=True)
    ap.add_argument("--model", required=True, help="a learned model: nsrm, nmn, ...")
    ap.add_argument("--checkpoint", type=Path, default=None)
    ap.add_argument("--part-checkpoint", action="append", default=[], metavar="NAME=PATH")
    ap.add_argument("--out", type=Path, default=None, help="default: results/MODEL")
    ap.add_argument("--run", type=Path, default=None, help="training run dir (model card)")
    args = ap.parse_args()
    args.out = args.out or Path("results") / args.model
    args.out.mkdir(parents=True, exist_ok=True)
    per_part = dict(x.split("=", 1) for x in args.part_checkpoint)
    report: dict[str, object] = {}
    for split in PARTS:
        data = args.data_root / split
        if not (data / "manifest.json").exists():
            print(f"-- {split}: no data at {data}, skipped")
            continue
        pred = args.out / (split.replace("/", "-") + ".jsonl")
        ckpt = per_part.get(split.split("-v")[0], args.checkpoint)
        cmd = [*_cli(), "predict", args.model, "--data", str(data), "--out", str(pred),
               "--quiet"] + (["--checkpoint", str(ckpt)] if ckpt else [])
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True)
        seconds = time.perf_counter() - t0
        scores = args.out / (split.replace("/", "-") + ".scores.json")
        subprocess.run([*_cli(), "score", str(pred), "--data", str(data), "--json",
                        str(scores), "--quiet"], check=True)
        res = json.loads(scores.read_text())
        n = res["counts"]["instances"] if "instances" in res.get("counts", {}) else None
        report[split] = {"predict_seconds": round(seconds, 2), "scores": str(scores), "n": n}
        _print(split, res, seconds)
    if args.run is not None and (args.run / "card.json").exists():
        card = json.loads((args.run / "card.json").read_text())
        cpu = f", {card['cpu_seconds']:.0f} s CPU" if "cpu_seconds" in card else ""
        print(f"\ntraining: {card['train_seconds']:.0f} s of training "
              f"({card['wall_seconds']:.0f} s wall{cpu}, {card['threads']} threads), "
              f"{card['parameters']:,} parameters")
        report["training"] = card
    (args.out / "bench.json").write_text(json.dumps(report, indent=1) + "\n")
    return 0


def _fmt(m: dict[str, object]) -> str:
    v, lo, hi = m.get("value"), m.get("ci_low"), m.get("ci_high")
    if v is None:
        return "—"
    ci = f" [{lo:.3f}, {hi:.3f}]" if lo is not None and hi is not None else ""
    return f"{v:.3f}{ci}"


def _print(split: str, res: dict[str, object], seconds: float) -> None:
    summary = res["summary"]
    assert isinstance(summary, dict)
    n = summary.get("iou", {}).get("n")
    print(f"\n== {split}  (n={n}; predict {seconds:.1f} s)")
    for k in SUMMARY:
        if k in summary:
            print(f"  {k:22s} {_fmt(summary[k])}")
    cats = res.get("per_category")
    if isinstance(cats, list):
        print("  paper table (IoU / IoU-M):")
        for name, cat, group in (("single-step", "steps", "1"), ("double-step", "steps", "2"),
                                 ("simple", "relational", "False"),
                                 ("complex", "relational", "True")):
            got = {r["metric"]: r for r in cats if r["category"] == cat and r["group"] == group}
            if "iou" in got and "iou_m" in got:
                print(f"    {name:12s} {got['iou']['value']:.3f} / {_fmt(got['iou_m'])}"
                      f"  (n={got['iou']['n']})")
        for cat in sorted({r["category"] for r in cats}):
            rows = [r for r in cats if r.get("category") == cat and r.get("metric") == "iou_m"]
            if rows:
                print(f"  IoU-M by {cat}: " + ", ".join(
                    f"{r['group']}: {r['value']:.3f} [{r['ci_low']:.3f}, {r['ci_high']:.3f}]"
                    f" n={r['n']}" for r in rows))


if __name__ == "__main__":
    raise SystemExit(main())
