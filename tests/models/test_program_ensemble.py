"""Program models read as one (``members`` > 1): the ensemble's scores are its members'
mean, its splitter cuts where their mean probability peaks, and a run of two members
trains both (one process each), puts them together into one checkpoint that predicts,
and resumes instead of training again."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from nsrmp_bench.cli.main import main
from nsrmp_bench.reference_model.nsrm2.config import NSRM2Config
from nsrmp_bench.reference_model.nsrm2.model import ConceptStepModel
from nsrmp_bench.reference_model.program.data import program_data, read_items
from nsrmp_bench.reference_model.program.ensemble import (
    EnsembleSplitter,
    EnsembleStep,
    member_seeds,
)
from nsrmp_bench.reference_model.program.inference import decode
from nsrmp_bench.reference_model.program.modules import Splitter, pad_tokens
from nsrmp_bench.reference_model.program.training import EpisodeBatch
from nsrmp_bench.reference_model.registry import load_model

pytestmark = [pytest.mark.torch]


def _members(k: int, vocab_size: int) -> list[ConceptStepModel]:
    out = []
    for seed in range(k):
        torch.manual_seed(seed)
        model = ConceptStepModel(vocab_size, NSRM2Config(concept_dim=8)).eval()
        with torch.no_grad():  # an untrained model is near uniform: make each its own
            for p in model.parameters():
                p.add_(0.5 * torch.randn_like(p))
        out.append(model)
    return out


def test_ensemble_step_is_the_mean_of_its_members() -> None:
    members = _members(3, 12)
    ensemble = EnsembleStep(members).eval()
    torch.manual_seed(5)
    crops = torch.randint(0, 255, (2, 4, 3, 48, 48), dtype=torch.uint8)
    mask = torch.tensor([[True, True, True, False], [True, True, True, True]])
    sizes = 0.06 + 0.01 * torch.rand(2, 4, 2)
    centres = torch.rand(2, 4, 3)
    tokens = torch.randint(2, 12, (2, 7))
    previous = torch.zeros(2, 4)
    with torch.no_grad():
        got = ensemble.step(ensemble.code(tokens), tokens,
                            ensemble.features(crops, mask, sizes), centres, previous, mask)
        each = [m.step(m.code(tokens), tokens, m.features(crops, mask, sizes), centres,
                       previous, mask) for m in members]
    for i in range(3):
        want = torch.stack([e[i] for e in each]).mean(0)
        assert torch.allclose(got[i], want, atol=1e-6, equal_nan=True)
    # and not any one member's (they differ, so the test can tell)
    assert not torch.allclose(got[0][mask], each[0][0][mask])


def test_ensemble_splitter_cuts_at_the_mean_probability() -> None:
    torch.manual_seed(0)
    a, b = Splitter(10).eval(), Splitter(10).eval()
    a.threshold, b.threshold = torch.tensor(0.2), torch.tensor(0.4)
    with torch.no_grad():
        a.out.bias.fill_(0.0)
    both = EnsembleSplitter([a, b]).eval()
    assert float(both.threshold) == pytest.approx(0.3)
    tokens = pad_tokens([[2, 3, 4, 5, 6, 7], [3, 3, 9]])
    with torch.no_grad():
        got = torch.sigmoid(both(tokens))
        want = (torch.sigmoid(a(tokens)) + torch.sigmoid(b(tokens))) / 2
    assert torch.allclose(got, want, atol=1e-6)
    assert bool((got[:, 0] == 0).all())  # no step starts at the first token
    # two copies of one splitter cut as it does
    with torch.no_grad():
        assert EnsembleSplitter([a, a]).cuts([[2, 3, 4, 5, 6, 7]]) == a.cuts([[2, 3, 4, 5, 6, 7]])


def test_member_seeds_do_not_overlap_across_run_seeds() -> None:
    assert member_seeds(0, 3) == [0, 1, 2]
    assert member_seeds(1, 3) == [3, 4, 5]


@pytest.mark.slow
@pytest.mark.sim
def test_a_run_of_two_members(tiny_paper: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    args = ["train", "nsrm-v2", "--data", str(tiny_paper), "--out", str(out), "--quiet",
            "--set", "members=2", "--set", "epochs_warmup=1", "--set", "epochs_single=2",
            "--set", "epochs_joint=1", "--set", "batch_size=16"]
    assert main(args) == 0
    for k in range(2):
        assert (out / f"member-{k}" / "best.pt").exists()
        card = json.loads((out / f"member-{k}" / "card.json").read_text())
        assert card["seed"] == k and card["config"]["members"] == 1
    log = [json.loads(x) for x in (out / "log.jsonl").read_text().splitlines()]
    assert {r.get("member") for r in log[:-1]} == {0, 1}
    assert log[-1]["stage"] == "ensemble" and log[-1]["members"] == 2
    card = json.loads((out / "card.json").read_text())
    assert card["config"]["members"] == 2
    assert card["best_score"] == pytest.approx(log[-1]["val_iou_m"], abs=1e-4)

    # the checkpoint is the two members read as one
    model = load_model("nsrm-v2", out / "best.pt")
    members = [load_model("nsrm-v2", out / f"member-{k}" / "best.pt") for k in range(2)]
    items, _ = read_items(tiny_paper / "val")
    data = program_data(items[:8], model.vocab, model.rule)
    batch = EpisodeBatch(data, list(range(8)))
    tok = pad_tokens(data.tokens[:8])
    with torch.no_grad():
        step = model.model.step
        got = step.step(step.code(tok), tok, step.features(batch.crops, batch.mask, batch.sizes),
                        batch.centres, torch.zeros(batch.mask.shape), batch.mask)[0]
        each = []
        for m in members:
            s = m.model.step
            each.append(s.step(s.code(tok), tok, s.features(batch.crops, batch.mask,
                                                              batch.sizes),
                               batch.centres, torch.zeros(batch.mask.shape), batch.mask)[0])
    assert torch.allclose(got, torch.stack(each).mean(0), atol=1e-6, equal_nan=True)
    decoded = decode(model.model.step, model.model.splitter, data, model.rule)
    assert len(decoded.steps) == 8 and all(decoded.steps)

    # the same command again resumes: nothing is trained, the checkpoint's bytes stay
    before = (out / "best.pt").read_bytes()
    member_log = (out / "member-0" / "log.jsonl").read_text()
    assert main(args) == 0
    assert (out / "member-0" / "log.jsonl").read_text() == member_log
    assert (out / "best.pt").read_bytes() == before
