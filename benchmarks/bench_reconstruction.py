"""Figures of the scene-reconstruction model: SSIM of its images of the predicted sub-goal
states, with the oracle's boxes, NSRM's boxes and the PyBullet reference row.

Usage::

    .venv/bin/python benchmarks/bench_reconstruction.py --data-root data [--limit 200]
        [--checkpoint PATH] [--run runs/recon] [--out results/recon]

For ``paper-v2/test`` and ``steps-v2/test`` it runs ``nsrmp-bench reconstruct`` (timed) on
the committed predictions files of the oracle and of NSRM
(``leaderboards/predictions/<part>--<model>.jsonl.gz``) with the network, and on the oracle's
with ``--renderer sim``, then prints SSIM over the whole image and inside the moved boxes
(overall, and per step index for steps-v2), images per second, the parameter count and,
with ``--run``, the training time from the run's model card. ``--limit N`` scores the first
N episodes of each file (``0``: the full parts), ``--sim-limit`` those of the sim rows.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

PARTS = ("paper-v2/test", "steps-v2/test")
ROWS = (("oracle boxes, network", "oracle-v1", "network"),
        ("NSRM boxes, network", "nsrm-v1", "network"),
        ("oracle positions, sim", "oracle-v1", "sim"))


def _cli() -> list[str]:
    return [str(Path(sys.executable).with_name("nsrmp-bench"))]


def main() -> int:
    """Run the rows and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data-root", type=Path, default=Path("data"))
    ap.add_argument("--predictions", type=Path, default=Path("leaderboards/predictions"))
    ap.add_argument("--limit", type=int, default=200)
    ap.add_argument("--sim-limit", type=int, default=50, help="episodes for the sim rows")
    ap.add_argument("--checkpoint", type=Path, default=None)
    ap.add_argument("--run", type=Path, default=None, help="training run dir (card.json)")
    ap.add_argument("--out", type=Path, default=Path("results/recon"))
    args = ap.parse_args()
    from nsrmp_bench.storage.split_root import find_part

    results: dict[str, dict[str, object]] = {}
    for part in PARTS:
        data = find_part(args.data_root, part)
        if data is None:
            print(f"{part}: no data under {args.data_root}; skipped")
            continue
        for label, model, renderer in ROWS:
            preds = args.predictions / f"{part.replace('/', '-')}--{model}.jsonl.gz"
            out = args.out / part.replace("/", "-") / f"{model}-{renderer}"
            cmd = [*_cli(), "reconstruct", str(preds), "--data", str(data), "--out", str(out),
                   "--renderer", renderer, "--no-images",
                   "--limit", str(args.sim_limit if renderer == "sim" else args.limit)]
            if args.checkpoint is not None and renderer == "network":
                cmd += ["--checkpoint", str(args.checkpoint)]
            t0 = time.perf_counter()
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            wall = time.perf_counter() - t0
            res = json.loads((out / "ssim.json").read_text("utf-8"))
            res["wall"] = wall
            results[f"{part} | {label}"] = res
    print(f"\nSSIM (skimage, 7x7 window); first {args.limit or 'all'} episodes per part "
          f"({args.sim_limit or 'all'} for sim)\n")
    print(f"{'part | boxes, renderer':48}{'steps':>7}{'whole':>8}{'region':>8}"
          f"{'final':>8}{'img/s':>8}")
    for key, res in results.items():
        s = res["summary"]
        assert isinstance(s, dict)
        rate = float(res["images"]) / max(float(res["seconds"]), 1e-9)  # type: ignore[arg-type]
        print(f"{key:48}{s['steps']:>7}{s['whole']:>8.3f}{s['region']:>8.3f}"
              f"{s['final_state']['region']:>8.3f}{rate:>8.1f}")
    for key, res in results.items():
        if not key.startswith("steps-v2"):
            continue
        s = res["summary"]
        assert isinstance(s, dict)
        print(f"\n{key}: by step index (whole / region)")
        print("  " + "  ".join(f"{k}: {b['whole']:.3f}/{b['region']:.3f} (n={b['steps']})"
                               for k, b in s["by_step"].items()))
    from nsrmp_bench.reference_model.registry import load_model

    net = load_model("reconstruction-v1", args.checkpoint)
    n_params = sum(p.numel() for p in net.model.parameters())
    print(f"\nparameters: {n_params:,}; checkpoint {net.checkpoint} "
          f"({net.checkpoint.stat().st_size / 1e6:.2f} MB)")
    if args.run is not None and (args.run / "card.json").exists():
        card = json.loads((args.run / "card.json").read_text("utf-8"))
        print(f"training: {card['train_seconds']} s in the loop, {card['wall_seconds']} s wall "
              f"(reading {card['read_seconds']} s), {card['threads']} threads")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
