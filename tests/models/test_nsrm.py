"""NSRM: a tiny real training run learns, checkpoints round-trip and are deterministic,
the shipped checkpoint predicts valid files that beat noop, and the model never reads
targets."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from nsrmp_bench.cli.main import main

torch = pytest.importorskip("torch")

pytestmark = [pytest.mark.torch, pytest.mark.sim]

TINY = [
    "--set", "epochs_attribute=0", "--set", "epochs_relational=25",
    "--set", "epochs_reinforce=0", "--set", "epochs_splitter=1",
    "--set", "epochs_multistep=0", "--set", "batch_size=16", "--set", "splitter_examples=64",
]


@pytest.fixture(scope="module")
def tiny_run(tiny_paper: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("run")
    assert main(["train", "nsrm-v1", "--data", str(tiny_paper), "--out", str(out), "--quiet",
                 *TINY]) == 0
    return out


@pytest.mark.slow
def test_tiny_training_learns(tiny_run: Path, tiny_paper: Path, tmp_path: Path,
                              iou_m_of: Callable[[Path, Path, Path], float]) -> None:
    log = [json.loads(x) for x in (tiny_run / "log.jsonl").read_text().splitlines()]
    losses = [r["loss"] for r in log if r["stage"] == "relational"]
    assert losses[-1] < 0.8 * losses[0], losses
    pred, noop = tmp_path / "nsrm.jsonl", tmp_path / "noop.jsonl"
    train = tiny_paper / "train"
    assert main(["predict", "nsrm-v1", "--data", str(train), "--out", str(pred),
                 "--checkpoint", str(tiny_run / "best.pt"), "--quiet"]) == 0
    assert main(["baseline", "noop", "--data", str(train), "--out", str(noop)]) == 0
    assert main(["check-submission", str(pred), "--split", "paper-v2/train", "--data",
                 str(train)]) == 0
    ours = iou_m_of(pred, train, tmp_path)
    floor = iou_m_of(noop, train, tmp_path)
    assert ours > floor + 0.1 and ours > 3 * floor, (ours, floor)
    card = json.loads((tiny_run / "card.json").read_text())
    assert card["parameters"] > 0 and "final boxes" in card["supervision"]


@pytest.mark.slow
def test_same_seed_same_checkpoint_bytes(tiny_paper: Path, tmp_path: Path) -> None:
    short = ["--set", "epochs_attribute=1", "--set", "epochs_relational=1",
             "--set", "epochs_reinforce=1", "--set", "epochs_splitter=1",
             "--set", "epochs_multistep=1", "--quiet"]
    runs = []
    for name in ("a", "b"):
        out = tmp_path / name
        assert main(["train", "nsrm-v1", "--data", str(tiny_paper), "--out", str(out),
                     *short]) == 0
        runs.append((out / "best.pt").read_bytes())
    assert runs[0] == runs[1]


@pytest.mark.slow
def test_resume_after_interruption_continues(tiny_paper: Path, tmp_path: Path) -> None:
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "r"
    cmd = ["train", "nsrm-v1", "--data", str(tiny_paper), "--out", str(out), "--quiet",
           "--set", "epochs_attribute=2", "--set", "epochs_relational=3",
           "--set", "epochs_reinforce=0", "--set", "epochs_splitter=0",
           "--set", "epochs_multistep=0"]
    proc = subprocess.Popen([sys.executable, "-m", "nsrmp_bench.cli.main", *cmd],
                            start_new_session=True)
    log = out / "log.jsonl"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        if log.exists() and log.read_text().count("\n") >= 1:
            break
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)  # interrupted after its first epoch
    proc.wait()
    done_before = log.read_text().count("\n")
    assert 1 <= done_before < 5
    assert main(cmd) == 0  # the same command resumes
    records = [json.loads(x) for x in log.read_text().splitlines()]
    pairs = [(r["stage"], r["epoch"]) for r in records]
    expected = [("attribute", 1), ("attribute", 2), ("relational", 1), ("relational", 2),
                ("relational", 3)]
    assert sorted(set(pairs), key=expected.index) == expected
    assert len(pairs) <= len(expected) + 1  # at most the epoch being killed is redone
    assert (out / "best.pt").exists()


@pytest.mark.slow
def test_checkpoint_round_trips(tiny_run: Path, tmp_path: Path) -> None:
    from nsrmp_bench.reference_model import load_model
    from nsrmp_bench.reference_model.checkpoints import save_checkpoint

    model = load_model("nsrm-v1", tiny_run / "best.pt")
    copy = save_checkpoint(tmp_path / "copy.pt", "nsrm-v1", model.config.to_dict(),
                           model.vocab.to_list(), model.model.state_dict())
    again = load_model("nsrm-v1", copy)
    a, b = model.model.state_dict(), again.model.state_dict()
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    assert again.vocab == model.vocab and again.config == model.config


@pytest.mark.slow
def test_model_never_reads_targets(tiny_run: Path, smoke_test: Path,
                                   hide_targets: Callable[[dict[str, Any]], dict[str, Any]]
                                   ) -> None:
    from nsrmp_bench.dataset import EpisodeDataset
    from nsrmp_bench.reference_model import load_model

    ds = EpisodeDataset(smoke_test, transform=hide_targets)
    items = [ds[i] for i in range(len(ds))]
    preds = list(load_model("nsrm-v1", tiny_run / "best.pt").predict(items))
    assert [p.id for p in preds] == ds.collection.ids


def test_shipped_checkpoint_predicts_and_beats_noop(
        smoke_test: Path, tmp_path: Path, iou_m_of: Callable[[Path, Path, Path], float]) -> None:
    pred, noop = tmp_path / "nsrm.jsonl", tmp_path / "noop.jsonl"
    assert main(["predict", "nsrm-v1", "--data", str(smoke_test), "--out", str(pred)]) == 0
    assert main(["check-submission", str(pred), "--split", "smoke-v2/test", "--data",
                 str(smoke_test)]) == 0
    assert main(["baseline", "noop", "--data", str(smoke_test), "--out", str(noop)]) == 0
    ours = iou_m_of(pred, smoke_test, tmp_path)
    floor = iou_m_of(noop, smoke_test, tmp_path)
    assert ours > floor + 0.05 and ours > 5 * floor, (ours, floor)
    header = json.loads(pred.read_text().splitlines()[0])["header"]
    assert header["model"] == "nsrm-v1" and header["split"] == "smoke-v2/test"


def test_evaluate_runs_the_model_and_scores_it_like_predict(
        smoke_test: Path, tmp_path: Path, iou_m_of: Callable[[Path, Path, Path], float]) -> None:
    root = tmp_path / "data"
    (root / "smoke-v2").mkdir(parents=True)
    (root / "smoke-v2" / "test").symlink_to(smoke_test, target_is_directory=True)
    pred = tmp_path / "nsrm.jsonl"
    assert main(["predict", "nsrm-v1", "--data", str(smoke_test), "--out", str(pred)]) == 0
    out = tmp_path / "results"
    assert main(["evaluate", "nsrm-v1", "--data-root", str(root), "--out", str(out),
                 "--quiet"]) == 0
    from nsrmp_bench.results.summary import Results

    run = Results.read(out).run("nsrm-v1", "smoke-v2/test")
    assert run is not None and run.kind == "reference"
    written = out / run.predictions
    assert written.read_bytes() == pred.read_bytes()
    assert run.metric("iou_m").value == iou_m_of(pred, smoke_test, tmp_path)


@pytest.mark.slow
def test_bad_input_is_a_clear_error(tiny_paper: Path, tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["predict", "nsrm-v1", "--data", str(tiny_paper), "--out",
                 str(tmp_path / "p.jsonl")]) == 2
    assert "split root holding the parts: train, val" in capsys.readouterr().err
    assert main(["predict", "nsrmm", "--data", str(tiny_paper / "val"), "--out",
                 str(tmp_path / "p.jsonl")]) == 2
    assert "did you mean 'nsrm'" in capsys.readouterr().err
    assert main(["train", "nsrm-v1", "--data", str(tiny_paper / "val"), "--out",
                 str(tmp_path / "r"), "--set", "epochs=3"]) == 2
    assert "not KEY=VALUE with a field" in capsys.readouterr().err
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    assert main(["predict", "nsrm-v1", "--data", str(tiny_paper / "val"), "--out",
                 str(tmp_path / "p.jsonl"), "--checkpoint", str(bad)]) == 2
    assert "cannot be read" in capsys.readouterr().err
