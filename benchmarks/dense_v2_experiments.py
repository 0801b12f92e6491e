"""The dense-v2 development runs and the transport ablation, on cached encodings.

Reads (once, then caches) the single-step episodes of ``DATA/train`` and ``DATA/val``
encoded as the dense models read them, then trains one dense model (``dense-v2``, the
transport; the v1 place stream it was compared with is in nsrmp-bench 0.2.0) with config
overrides through the shared training loop, printing validation identification and
placement after every epoch and the training seconds. The figures are the in-loop ones
(``val_accuracy``: the picked object is the moved one; the place lies in its box after the
step), on the single-step episodes of val.

Usage::

    nice -n 10 .venv/bin/python benchmarks/dense_v2_experiments.py --data data/paper-v2 \
        --cache /tmp/dense-cache --model dense-v2 --set epochs=2 --set threads=1
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import torch

from nsrmp_bench.reference_model.checkpoints import read_torch_file
from nsrmp_bench.reference_model.contract import parse_value
from nsrmp_bench.reference_model.dense import val_accuracy
from nsrmp_bench.reference_model.dense.inputs import DenseInputs, encode_part
from nsrmp_bench.reference_model.registry import get_model
from nsrmp_bench.reference_model.tokens import Vocabulary
from nsrmp_bench.reference_model.training import Stage, train_stages


def _encoded(data: Path, cache: Path, scale: int) -> tuple[DenseInputs, DenseInputs, int]:
    path = cache / f"{data.name}-scale{scale}.pt"
    if not path.exists():
        cache.mkdir(parents=True, exist_ok=True)
        train, vocab = encode_part(data / "train", None, scale, single_step=True,
                                   targets=True, workers=2)
        val, _ = encode_part(data / "val", vocab, scale, single_step=True, targets=True,
                             limit=500)
        torch.save({"train": _plain(train), "val": _plain(val), "vocab": vocab.to_list()},
                   path)
    payload = read_torch_file(path, "cache file")
    return (_inputs(payload["train"]), _inputs(payload["val"]),
            len(Vocabulary(tuple(payload["vocab"]))))


def _plain(inputs: DenseInputs) -> dict[str, object]:
    """The inputs as tensors, numbers and containers (read back with weights_only=True)."""
    fields = {f.name: getattr(inputs, f.name) for f in dataclasses.fields(inputs)}
    return {**fields, "boxes": [torch.from_numpy(b) for b in inputs.boxes]}


def _inputs(plain: dict[str, Any]) -> DenseInputs:
    return DenseInputs(**{**plain, "boxes": [b.numpy() for b in plain["boxes"]],
                          "image_size": tuple(plain["image_size"])})


def main() -> None:
    """Train one configuration and print its validation figures."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, required=True)
    parser.add_argument("--cache", type=Path, required=True)
    parser.add_argument("--model", default="dense-v2")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    cls = get_model(args.model).model_cls()
    types = cls.config_cls.field_types()
    sets = dict(s.split("=", 1) for s in args.set)
    cfg = cls.config_cls(**{k: parse_value(v, types[k]) for k, v in sets.items()})
    torch.set_num_threads(cfg.threads)  # type: ignore[attr-defined]
    train, val, n_vocab = _encoded(args.data, args.cache, cfg.scale)  # type: ignore[attr-defined]
    torch.manual_seed(args.seed)
    net = cls.build_network(cfg, n_vocab, {})
    figures: list[dict[str, float]] = []

    def validate(stage: Stage) -> float:
        ident, place = val_accuracy(net, val)  # type: ignore[arg-type]
        figures.append({"identification": ident, "placement": place})
        print(json.dumps({"epoch": len(figures), "identification": round(ident, 4),
                          "placement": round(place, 4)}), flush=True)
        return (ident + place) / 2

    stages = cls.stages(cfg, net, train)  # type: ignore[attr-defined]
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        state = train_stages(net, stages, Path(out), seed=args.seed, validate=validate,
                             on_best=lambda: None, quiet=True, score_name="val_id_pl")
        losses = [json.loads(x)["loss"] for x in (Path(out) / "log.jsonl").read_text().splitlines()]
    print(json.dumps({"model": args.model, "set": sets, "train_seconds": round(state.seconds, 1),
                      "wall_seconds": round(time.perf_counter() - t0, 1),
                      "parameters": sum(p.numel() for p in net.parameters()),
                      "losses": [round(x, 3) for x in losses], "val": figures}))


if __name__ == "__main__":
    main()
