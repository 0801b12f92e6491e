"""NMN+: a tiny real training run learns, same seed gives the same bytes, the shipped
checkpoint predicts valid files that beat noop, and the model never reads targets."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from nsrmp_bench.cli.main import main

torch = pytest.importorskip("torch")

pytestmark = [pytest.mark.torch, pytest.mark.sim]

TINY = ["--set", "epochs_single=20", "--set", "epochs_splitter=1",
        "--set", "epochs_multistep=0", "--set", "batch_size=16",
        "--set", "splitter_examples=64"]


@pytest.fixture(scope="module")
def tiny_nmn(tiny_paper: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("nmn-run")
    assert main(["train", "nmn-v1", "--data", str(tiny_paper), "--out", str(out), "--quiet",
                 *TINY]) == 0
    return out


@pytest.mark.slow
def test_tiny_training_learns(tiny_nmn: Path, tiny_paper: Path, tmp_path: Path,
                              iou_m_of: Callable[[Path, Path, Path], float]) -> None:
    log = [json.loads(x) for x in (tiny_nmn / "log.jsonl").read_text().splitlines()]
    losses = [r["loss"] for r in log if r["stage"] == "single"]
    assert losses[-1] < 0.8 * losses[0], losses
    pred, noop = tmp_path / "nmn.jsonl", tmp_path / "noop.jsonl"
    train = tiny_paper / "train"
    assert main(["predict", "nmn-v1", "--data", str(train), "--out", str(pred),
                 "--checkpoint", str(tiny_nmn / "best.pt"), "--quiet"]) == 0
    assert main(["baseline", "noop", "--data", str(train), "--out", str(noop)]) == 0
    assert main(["check-submission", str(pred), "--split", "paper-v2/train", "--data",
                 str(train)]) == 0
    ours, floor = iou_m_of(pred, train, tmp_path), iou_m_of(noop, train, tmp_path)
    assert ours > floor + 0.1 and ours > 3 * floor, (ours, floor)
    card = json.loads((tiny_nmn / "card.json").read_text())
    assert card["model"] == "nmn-v1" and card["parameters"] > 0
    assert "final boxes" in card["supervision"]


@pytest.mark.slow
def test_same_seed_same_checkpoint_bytes(tiny_paper: Path, tmp_path: Path) -> None:
    short = ["--set", "epochs_single=1", "--set", "epochs_splitter=1",
             "--set", "epochs_multistep=1", "--set", "splitter_examples=32", "--quiet"]
    runs = []
    for name in ("a", "b"):
        out = tmp_path / name
        assert main(["train", "nmn-v1", "--data", str(tiny_paper), "--out", str(out),
                     *short]) == 0
        runs.append((out / "best.pt").read_bytes())
    assert runs[0] == runs[1]


@pytest.mark.slow
def test_model_never_reads_targets(tiny_nmn: Path, smoke_test: Path,
                                   hide_targets: Callable[[dict[str, Any]], dict[str, Any]]
                                   ) -> None:
    from nsrmp_bench.dataset import EpisodeDataset
    from nsrmp_bench.reference_model import load_model

    ds = EpisodeDataset(smoke_test, transform=hide_targets)
    items = [ds[i] for i in range(len(ds))]
    preds = list(load_model("nmn-v1", tiny_nmn / "best.pt").predict(items))
    assert [p.id for p in preds] == ds.collection.ids


def test_shipped_checkpoint_predicts_and_beats_noop(
        smoke_test: Path, tmp_path: Path, iou_m_of: Callable[[Path, Path, Path], float]) -> None:
    pred, noop = tmp_path / "nmn.jsonl", tmp_path / "noop.jsonl"
    assert main(["predict", "nmn-v1", "--data", str(smoke_test), "--out", str(pred)]) == 0
    assert main(["check-submission", str(pred), "--split", "smoke-v2/test", "--data",
                 str(smoke_test)]) == 0
    assert main(["baseline", "noop", "--data", str(smoke_test), "--out", str(noop)]) == 0
    ours, floor = iou_m_of(pred, smoke_test, tmp_path), iou_m_of(noop, smoke_test, tmp_path)
    assert ours > floor + 0.05 and ours > 3 * floor, (ours, floor)
    header = json.loads(pred.read_text().splitlines()[0])["header"]
    assert header["model"] == "nmn-v1" and header["split"] == "smoke-v2/test"


def test_nmn_shares_nsrm_parts() -> None:
    from nsrmp_bench.reference_model.nmn import NMNConfig
    from nsrmp_bench.reference_model.nmn.model import NMN
    from nsrmp_bench.reference_model.nsrm.modules import (
        ActionSimulator,
        Splitter,
        VisualExtractor,
        WordEncoder,
    )

    model = NMN(50, NMNConfig())
    assert isinstance(model.visual, VisualExtractor) and isinstance(model.splitter, Splitter)
    assert isinstance(model.encoder, WordEncoder)
    assert isinstance(model.simulator, ActionSimulator)
