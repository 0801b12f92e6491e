"""NSRM v2 and NMN+ v2 on the shared program parts: a tiny run learns, the shipped
checkpoints predict valid files without reading targets, ``evaluate`` scores a model as
``predict`` and ``score`` do, bad input is a clear error, an interrupted run resumes, a
checkpoint round-trips, and the defects D1, D5 and D8 of v1 stay fixed."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

from nsrmp_bench.cli.main import main
from nsrmp_bench.dataset import EpisodeDataset
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.reference_model.nsrm2.config import NSRM2Config
from nsrmp_bench.reference_model.nsrm2.model import ROLES, ConceptStepModel
from nsrmp_bench.reference_model.program.data import program_data, read_items
from nsrmp_bench.reference_model.program.inference import Oracle, decode
from nsrmp_bench.reference_model.program.modules import Splitter
from nsrmp_bench.reference_model.program.scene3d import ActionRule
from nsrmp_bench.reference_model.program.training import option_scores
from nsrmp_bench.reference_model.registry import load_model
from nsrmp_bench.reference_model.tokens import Vocabulary

pytestmark = [pytest.mark.sim, pytest.mark.torch]


@pytest.fixture(scope="module")
def tiny_v2(tiny_paper: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    # one member at two threads: the single-member run these figures were set on (one
    # thread gives other float sums and, on 320 episodes, a slower start: 3.86 -> 3.14
    # after 12 epochs, against 2.48 at two threads). Float sums differ by CPU kind too: on
    # an AVX-512 AMD EPYC two threads gave 3.85 -> 3.10 after 12 epochs, so the run has 16
    out = tmp_path_factory.mktemp("nsrm2-run")
    assert main(["train", "nsrm-v2", "--data", str(tiny_paper), "--out", str(out), "--quiet",
                 "--set", "epochs_single=16", "--set", "epochs_joint=1",
                 "--set", "members=1", "--set", "threads=2"]) == 0
    return out


def test_config_refuses_an_unknown_filter_link() -> None:
    with pytest.raises(InvalidArgument, match=r"filter_link = 'sigmoid'.*one of"):
        NSRM2Config(filter_link="sigmoid")


@pytest.mark.slow
def test_tiny_run_learns(tiny_v2: Path, tiny_paper: Path, tmp_path: Path,
                         iou_m_of: Callable[[Path, Path, Path], float]) -> None:
    log = [json.loads(x) for x in (tiny_v2 / "log.jsonl").read_text().splitlines()]
    single = [r["loss"] for r in log if r["stage"] in ("warmup", "single")]
    assert single[-1] < 0.8 * single[0]
    assert {"val_subject_relational", "val_subject_attribute", "val_split"} <= set(log[-1])
    card = json.loads((tiny_v2 / "card.json").read_text())
    assert card["model"] == "nsrm-v2" and card["parameters"] > 0
    assert "no gold program" in card["supervision"]
    train = tiny_paper / "train"
    pred, noop = tmp_path / "v2.jsonl", tmp_path / "noop.jsonl"
    assert main(["predict", "nsrm-v2", "--data", str(train), "--out", str(pred),
                 "--checkpoint", str(tiny_v2 / "best.pt")]) == 0
    assert main(["baseline", "noop", "--data", str(train), "--out", str(noop)]) == 0
    # far above doing nothing: 0.089 against 0.015 with the leaky filters (log-sigmoid
    # filters reached 0.158 on this tiny run; the leak learns slower here, a second joint
    # epoch gives 0.094, while on paper-v2 it is the better of the two: see the card)
    assert iou_m_of(pred, train, tmp_path) > iou_m_of(noop, train, tmp_path) + 0.05


@pytest.mark.parametrize("model", ["nsrm-v2", "nmn-v2"])
def test_shipped_checkpoint_predicts_without_targets(
        model: str, smoke_test: Path, hide_targets: Callable[[dict[str, Any]], dict[str, Any]],
        tmp_path: Path) -> None:
    ds = EpisodeDataset(smoke_test, transform=hide_targets)
    items = [ds[i] for i in range(len(ds))]
    preds = list(load_model(model).predict(items))
    assert len(preds) == len(items) and all(p.program for p in preds)
    pred = tmp_path / "p.jsonl"
    assert main(["predict", model, "--data", str(smoke_test), "--out", str(pred)]) == 0
    assert main(["check-submission", str(pred), "--split", "smoke-v2/test", "--data",
                 str(smoke_test)]) == 0
    header = json.loads(pred.read_text().splitlines()[0])["header"]
    assert header["model"] == model and header["split"] == "smoke-v2/test"


def test_evaluate_runs_the_model_and_scores_it_like_predict(
        smoke_test: Path, tmp_path: Path, iou_m_of: Callable[[Path, Path, Path], float]) -> None:
    root = tmp_path / "data"
    (root / "smoke-v2").mkdir(parents=True)
    (root / "smoke-v2" / "test").symlink_to(smoke_test, target_is_directory=True)
    pred = tmp_path / "nsrm.jsonl"
    assert main(["predict", "nsrm-v2", "--data", str(smoke_test), "--out", str(pred)]) == 0
    out = tmp_path / "results"
    assert main(["evaluate", "nsrm-v2", "--data-root", str(root), "--out", str(out),
                 "--quiet"]) == 0
    from nsrmp_bench.results.summary import Results

    run = Results.read(out).run("nsrm-v2", "smoke-v2/test")
    assert run is not None and run.kind == "reference"
    written = out / run.predictions
    assert written.read_bytes() == pred.read_bytes()
    assert run.metric("iou_m").value == iou_m_of(pred, smoke_test, tmp_path)


@pytest.mark.slow
def test_bad_input_is_a_clear_error(tiny_paper: Path, tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["predict", "nsrm-v2", "--data", str(tiny_paper), "--out",
                 str(tmp_path / "p.jsonl")]) == 2
    assert "split root holding the parts: train, val" in capsys.readouterr().err
    assert main(["predict", "nsrmm", "--data", str(tiny_paper / "val"), "--out",
                 str(tmp_path / "p.jsonl")]) == 2
    assert "did you mean 'nsrm'" in capsys.readouterr().err
    assert main(["train", "nsrm-v2", "--data", str(tiny_paper / "val"), "--out",
                 str(tmp_path / "r"), "--set", "epochs=3"]) == 2
    assert "not KEY=VALUE with a field" in capsys.readouterr().err
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    assert main(["predict", "nsrm-v2", "--data", str(tiny_paper / "val"), "--out",
                 str(tmp_path / "p.jsonl"), "--checkpoint", str(bad)]) == 2
    assert "cannot be read" in capsys.readouterr().err


@pytest.mark.slow
def test_resume_after_interruption_continues(tiny_paper: Path, tmp_path: Path) -> None:
    """The one training loop (every model's): a run killed after an epoch resumes from
    ``last.pt`` with the same command and redoes at most the epoch it was killed in."""
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "r"
    cmd = ["train", "nsrm-v2", "--data", str(tiny_paper), "--out", str(out), "--quiet",
           "--set", "members=1", "--set", "epochs_warmup=2", "--set", "epochs_single=3",
           "--set", "epochs_joint=0"]
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
    expected = [("warmup", 1), ("warmup", 2), ("single", 1), ("single", 2), ("single", 3)]
    assert sorted(set(pairs), key=expected.index) == expected
    assert len(pairs) <= len(expected) + 1  # at most the epoch being killed is redone
    assert (out / "best.pt").exists()


@pytest.mark.slow
def test_checkpoint_round_trips(tiny_v2: Path, tmp_path: Path) -> None:
    from nsrmp_bench.reference_model.checkpoints import save_checkpoint

    model = load_model("nsrm-v2", tiny_v2 / "best.pt")
    copy = save_checkpoint(tmp_path / "copy.pt", "nsrm-v2", model.config.to_dict(),
                           model.vocab.to_list(), model.model.state_dict())
    again = load_model("nsrm-v2", copy)
    a, b = model.model.state_dict(), again.model.state_dict()
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    assert again.vocab == model.vocab and again.config == model.config


def test_d1_one_action_encoding(smoke_test: Path) -> None:
    """Training scores a program's action by the log-probability inference takes the
    argmax of: the action rule only ever sees one of the three actions."""
    model = load_model("nsrm-v2")
    items, _ = read_items(smoke_test)
    data = program_data(items, model.vocab, model.rule)
    step = model.model.step
    from nsrmp_bench.reference_model.program.consistent import Consistent
    from nsrmp_bench.reference_model.program.training import EpisodeBatch, pad_tokens

    tok = pad_tokens(data.tokens[:1])
    batch = EpisodeBatch(data, [0])
    with torch.no_grad():
        feats = step.features(batch.crops, batch.mask, batch.sizes)
        s_lp, b_lp, a_lp = step.step(step.code(tok), tok, feats, batch.centres,
                                     torch.zeros(batch.mask.shape), batch.mask)
        for action in range(3):
            data.consistent = [Consistent(np.array([[0, 1, action]]), np.zeros((0, 6), int),
                                          np.zeros((0, len(data.states[0]), 3)))]
            got = option_scores(step, data, batch, feats, [[0]])[0][0]
            want = s_lp[0, 0] + b_lp[0, 1] + a_lp[0, action]
            assert torch.allclose(got, want, atol=1e-5)
    decoded = decode(step, model.model.splitter, data, model.rule,
                     Oracle(cuts=[[] for _ in range(len(data))]))
    assert decoded.steps[0][0][0] == int(a_lp[0].argmax())


def _hand_model(vocab: Vocabulary) -> ConceptStepModel:
    """A step model whose words mean by hand, on one-hot object features: ``red`` holds of
    objects 0 and 1, ``blue`` of object 2, ``left`` is "left of" (world -x by more than
    7.5 cm); its parser is fixed: ``red`` heads the subject, ``left`` is its relation,
    ``blue`` its anchor."""
    model = ConceptStepModel(len(vocab), NSRM2Config(concept_dim=4))
    idx = {w: i for i, w in enumerate(vocab.words)}
    with torch.no_grad():
        model.concept.weight.zero_()
        model.concept_bias.weight.fill_(20.0)
        for word, dims in (("red", (0, 1)), ("blue", (2,))):
            model.concept_bias.weight[idx[word]] = -20.0
            for d in dims:
                model.concept.weight[idx[word], d] = 40.0
        model.relation.weight[idx["left"]] = torch.tensor([-20.0, 0.0, 0.0])
        model.relation_bias.weight[idx["left"]] = -1.5 * 20.0
    roles = {idx["red"]: "subject", idx["left"]: "subject-relation",
             idx["blue"]: "subject-anchor", idx["go"]: "none"}

    def fixed_code(pieces: torch.Tensor) -> torch.Tensor:
        code = torch.zeros((*pieces.shape, len(ROLES)))
        for word, role in roles.items():
            code[..., ROLES.index(role)] += (pieces == word).float()
        return code

    model.code = fixed_code  # type: ignore[method-assign]
    model.perception = _OneHot()  # type: ignore[assignment]
    return model


class _OneHot(torch.nn.Module):
    """Object i's features: the i-th unit vector of 4 dims."""

    def forward(self, crops: torch.Tensor, mask: torch.Tensor,
                sizes: torch.Tensor) -> torch.Tensor:
        b, n = mask.shape
        out = torch.zeros((b, n, 4))
        for i in range(min(n, 4)):
            out[:, i, i] = 1.0
        return out


def test_d5_relations_read_on_the_current_state(smoke_test: Path) -> None:
    """"The red one left of the blue one" in step 2 resolves on the world step 1 left.

    Red 0 is left of blue 2 and red 1 right of it; step 1 puts red 0 to the right of red
    1, so on the new world red 0 is the red object furthest from being left of blue:
    step 2 must pick red 1, where the initial world would pick red 0."""
    vocab = Vocabulary(("<pad>", "<unk>", "blue", "go", "left", "red"))
    model = _hand_model(vocab)
    items, _ = read_items(smoke_test)
    rule = ActionRule()
    data = program_data(items[:1], vocab, rule)
    state = data.states[0]
    assert len(state) == 3
    state.centres[:, 0] = [-0.2, 0.2, 0.0]
    state.centres[:, 1] = 0.0
    data.tokens = [vocab.encode("go red left blue")]
    splitter = Splitter(len(vocab))
    # step 1 ("go"): red 0 to the right of red 1; step 2: "red left blue"
    oracle = Oracle(cuts=[[1]], grounding=[[(0, 1)]], actions=[[2]])
    decoded = decode(model, splitter, data, rule, oracle)
    assert decoded.centres[0][0, 0] > 0.2 + 0.075
    assert decoded.steps[0][1][1] == 1
    # the same piece on the initial world picks red 0: the answer moved with the world
    from nsrmp_bench.reference_model.program.training import EpisodeBatch, pad_tokens

    batch = EpisodeBatch(data, [0])
    tok = pad_tokens([data.tokens[0][1:]])
    feats = model.perception(batch.crops, batch.mask, batch.sizes)
    s_lp, _, _ = model.step(model.code(tok), tok, feats, batch.centres,
                            torch.zeros(batch.mask.shape), batch.mask)
    assert int(s_lp[0].argmax()) == 0


def _parsed_scene(vocab: Vocabulary, words: tuple[str, ...],
                  roles: tuple[tuple[int, str, float], ...], xs: tuple[float, ...]
                  ) -> tuple[torch.Tensor, ...]:
    """A piece of ``words`` with a fixed parse (token, role, probability) and one-hot
    objects at ``xs`` along world x: tokens, role code, centres, mask and features."""
    idx = {w: i for i, w in enumerate(vocab.words)}
    tokens = torch.tensor([[idx[w] for w in words]])
    code = torch.zeros((1, len(words), len(ROLES)))
    for t, role, p in roles:
        code[0, t, ROLES.index(role)] = p
    centres = torch.zeros((1, len(xs), 3))
    centres[0, :, 0] = torch.tensor(xs)
    mask = torch.ones((1, len(xs)), dtype=torch.bool)
    feats = _OneHot()(torch.zeros(0), mask, torch.zeros(0))
    return tokens, code, centres, mask, feats


def test_a_relation_word_before_a_references_head_is_not_its_relation() -> None:
    """"red left blue, go, blue": the subject's relation word ``left`` also reads a little
    as the base's relation (the parser is soft). With ``relation_after_head`` it counts
    for the base only after the base's head began, so the base is the blue object; without
    it, that leak silences half of the base's head and makes the base "left of
    something", and the base is a red object."""
    vocab = Vocabulary(("<pad>", "<unk>", "blue", "go", "left", "red"))
    tokens, code, centres, mask, feats = _parsed_scene(
        vocab, ("red", "left", "blue", "go", "blue"),
        ((0, "subject", 1.0), (1, "subject-relation", 0.5), (1, "base-relation", 0.5),
         (2, "subject-anchor", 1.0), (3, "none", 1.0), (4, "base", 1.0)),
        (-0.2, 0.0, 0.2))
    bases = {}
    for flag in (True, False):
        model = _hand_model(vocab)
        model.cfg = NSRM2Config(concept_dim=4, relation_after_head=flag)
        _, b_lp, _ = model.step(code, tokens, feats, centres, torch.zeros((1, 3)), mask)
        bases[flag] = int(b_lp[0].argmax())
    assert bases == {True: 2, False: 0}


@pytest.mark.parametrize(("link", "learns"), [("logsigmoid", False), ("linear", True),
                                               ("leaky", True)])
def test_a_word_true_of_the_wrong_object_can_unlearn_it(link: str, learns: bool) -> None:
    """"cube" scores 12 on a cube and 10 on a dice (it was learnt before the two looked
    different) and the subject is the cube. Through log sigmoid both scores sit at 0,
    the subject is a coin toss, and the gradient that would lower "cube" on the dice is
    e^-10 of the loss's: the word cannot unlearn the dice. Linear and leaky links keep
    the difference and a gradient of the loss's size."""
    model = ConceptStepModel(3, NSRM2Config(concept_dim=4, filter_link=link))
    tokens = torch.tensor([[2]])
    code = torch.zeros((1, 1, len(ROLES)))
    code[0, 0, ROLES.index("subject")] = 1.0
    mask = torch.ones((1, 2), dtype=torch.bool)
    feats = torch.tensor([[[12.0, 0, 0, 0], [10.0, 0, 0, 0]]], requires_grad=True)
    with torch.no_grad():
        model.concept.weight[2, 0] = 1.0
    s_lp, _, _ = model.step(code, tokens, feats, torch.zeros((1, 2, 3)),
                            torch.zeros((1, 2)), mask)
    loss = -s_lp[0, 0]
    loss.backward()
    assert feats.grad is not None
    pull = float(feats.grad[0, 1, 0])  # descent lowers "cube" on the dice by this much
    assert (float(s_lp[0, 0].detach().exp()) > 0.52) == learns
    assert (pull > 0.01) == learns


@pytest.mark.parametrize(("after", "margin"), [(False, 0.2), (True, 2.0)])
def test_it_prefers_the_previous_subject_by_its_whole_affinity(after: bool,
                                                               margin: float) -> None:
    """The base is "it" (word 2) with an affinity of 2 for the object the previous step
    moved (object 1), and the word's concept scores both objects 10. Inside the leaky
    link the affinity moves object 1 from log sigmoid(10) + 1 to log sigmoid(12) + 1.2:
    0.2 nats, all but the leak's share lost to saturation. After the link
    (``previous_after_link``) it is the whole 2 nats."""
    model = ConceptStepModel(3, NSRM2Config(concept_dim=4, previous_after_link=after))
    tokens = torch.tensor([[2]])
    code = torch.zeros((1, 1, len(ROLES)))
    code[0, 0, ROLES.index("base")] = 1.0
    mask = torch.ones((1, 2), dtype=torch.bool)
    feats = torch.tensor([[[10.0, 0, 0, 0], [10.0, 0, 0, 0]]])
    with torch.no_grad():
        model.concept.weight[2, 0] = 1.0
        model.previous.weight[2, 0] = 2.0
    _, b_lp, _ = model.step(code, tokens, feats, torch.zeros((1, 2, 3)),
                            torch.tensor([[0.0, 1.0]]), mask)
    assert float(b_lp[0, 1] - b_lp[0, 0]) == pytest.approx(margin, abs=1e-3)
    assert NSRM2Config.from_dict({}).previous_after_link is False


def test_d8_positions_of_a_correct_program_pass_success_3d(
        smoke_test: Path, tmp_path: Path) -> None:
    """The gold program through NSRM v2's action rule: its positions are the objects'
    centres, so the scorer's 3D success (2 cm) passes where the boxes do."""
    model = load_model("nsrm-v2")
    items, ds = read_items(smoke_test)
    grounded = [it["targets"]["grounded"].tolist() for it in items]
    # every step is the gold one whatever its piece says: cut after tokens 1..S-1
    oracle = Oracle(cuts=[list(range(1, len(g))) for g in grounded],
                    actions=[[a for a, _, _ in g] for g in grounded],
                    grounding=[[(s, r) for _, s, r in g] for g in grounded])
    from nsrmp_bench.reference_model.predictions import write_model_predictions

    pred = tmp_path / "gold.jsonl"
    write_model_predictions(pred, ds.collection.split, "nsrm-v2",
                            model.predict(items, oracle))
    out = tmp_path / "s.json"
    assert main(["score", str(pred), "--data", str(smoke_test), "--json", str(out),
                 "--quiet", "--n-boot", "0"]) == 0
    summary = json.loads(out.read_text())["summary"]
    assert summary["success_3d"]["value"] >= 0.75
    assert summary["iou_m"]["value"] >= 0.8


def test_action_rule_fit_recovers_the_rule_that_moved_the_boxes(smoke_test: Path) -> None:
    """Final boxes made by a known rule (one step per episode, every action): the fit
    recovers a rule that explains them as well as the true one, starting from the
    default; and a rule of the first design (three values) loads as the same moves."""
    from nsrmp_bench.geometry.boxes import box_iou
    from nsrmp_bench.reference_model.program.consistent import fit_rule
    from nsrmp_bench.reference_model.program.scene3d import move, project_boxes

    items, _ = read_items(smoke_test)
    vocab = Vocabulary(("<pad>", "<unk>"))
    true = ActionRule(0.3, (0.2, 0.3, 0.1, 0.2, 0.004), (0.5, 0.4, 0.3, 0.2, 0.01))
    data = program_data(items, vocab, true)
    rng = np.random.default_rng(0)
    states, finals, programs = [], [], []
    for _ in range(8):
        for state in data.states:
            s, b = rng.choice(len(state), size=2, replace=False)
            a = int(rng.integers(3))
            c = move(state, state.centres[None].copy(), np.array([s]), np.array([b]),
                     np.array([a]), true)
            states.append(state)
            finals.append(project_boxes(state, c)[0])
            programs.append((int(s), int(b), a))

    def mean_iou(rule: ActionRule) -> float:
        out = []
        for state, final, (s, b, a) in zip(states, finals, programs, strict=True):
            c = move(state, state.centres[None].copy(), np.array([s]), np.array([b]),
                     np.array([a]), rule)
            out.append(float(box_iou(project_boxes(state, c)[0][s:s + 1], final[s:s + 1])[0]))
        return float(np.mean(out))

    fitted = fit_rule(states, finals)
    assert mean_iou(fitted) > 0.97
    assert mean_iou(fitted) > mean_iou(ActionRule()) + 0.02
    old = ActionRule.from_values([0.3, 0.8, 1.6])
    assert old == ActionRule(0.3, (0.4, 0.4, 0.0, 0.0, 0.0), (0.8, 0.8, 0.0, 0.0, 0.0))
    assert ActionRule.from_values(fitted.values()) == fitted
    assert ActionRule.from_dict(json.loads(json.dumps(fitted.to_dict()))) == fitted


def test_decoder_keeps_to_the_stacks_the_dsl_allows() -> None:
    """After "0 on 1": 1 cannot be picked up, nothing goes onto 1 or (for 0) onto its own
    support; beside moves may still name 1. A stack of three takes nothing more."""
    from nsrmp_bench.reference_model.program.inference import legal_pairs

    top, left = 0, 1
    fresh = legal_pairs([-1, -1, -1], top, 3)
    assert fresh.tolist() == (~np.eye(3, dtype=bool)).tolist()
    after = legal_pairs([1, -1, -1, -1], top, 4)
    assert not after[1].any()  # subject covered
    assert not after[:, 1].any()  # reference covered
    assert after[0, 2] and after[2, 0] and after[0, 3]
    beside = legal_pairs([1, -1, -1, -1], left, 4)
    assert beside[0, 1] and beside[2, 1] and not beside[1].any()
    full = legal_pairs([1, 2, -1, -1], top, 4)
    assert not full[3, 0] and full[0, 3]
    assert int(full.sum()) == 1



def test_splitter_threshold_is_the_low_end_of_what_counts_training_episodes_right() -> None:
    """Peaks of cut episodes hold 0.6 (their second 0.05), those of uncut ones 0.2: every
    threshold in (0.2, 0.6] counts all right, and the fit takes the lowest (longer
    instructions hold weaker peaks). One uncut episode in 200 with a 0.5 peak (teacher
    noise) does not move it; ten in 200 do, to above them."""
    from nsrmp_bench.reference_model.program.training import fit_threshold

    def episodes(noisy: int) -> tuple[torch.Tensor, torch.Tensor]:
        top = [[0.6, 0.05]] * 100 + [[0.2, 0.0]] * (100 - noisy) + [[0.5, 0.0]] * noisy
        cut = [True] * 100 + [False] * 100
        return torch.tensor(top, dtype=torch.float64), torch.tensor(cut)

    assert fit_threshold(*episodes(0)) == pytest.approx(0.21)
    assert fit_threshold(*episodes(1)) == pytest.approx(0.21)
    assert fit_threshold(*episodes(10)) == pytest.approx(0.51)


def _boundary_probabilities(logits: torch.Tensor) -> Callable[[torch.Tensor], torch.Tensor]:
    def forward(tokens: torch.Tensor) -> torch.Tensor:
        out = logits[None].expand(len(tokens), -1).clone()
        out[:, 0] = float("-inf")
        return out
    return forward


def test_boundary_peaks_closer_than_a_step_are_one_boundary() -> None:
    """paper-v2/test 000308's probabilities: 0.39 at "and" inside the base's reference and
    0.31 at "after" five tokens later (the teacher's steps read the same cut at either).
    With the window as the gap (checkpoints from before ``splitter_gap``) both are cuts,
    three steps; with a gap of 5 they are one boundary, two steps. Peaks further apart
    than the gap are still two boundaries."""
    probs = torch.full((40,), 0.001)
    probs[23], probs[28] = 0.39, 0.31
    logits = torch.logit(probs)
    tokens = [list(range(2, 42))]
    cuts = {}
    for gap in (3, 5):
        splitter = Splitter(50, gap=gap).eval()
        splitter.threshold = torch.tensor(0.23)
        splitter.forward = _boundary_probabilities(logits)  # type: ignore[method-assign]
        cuts[gap] = splitter.cuts(tokens)[0]
    assert cuts[3] == [23, 28]
    assert cuts[5] == [23]
    probs[28] = 0.001
    probs[30] = 0.31  # seven tokens on: a step can be that short
    splitter.forward = _boundary_probabilities(torch.logit(probs))  # type: ignore[method-assign]
    assert splitter.cuts(tokens)[0] == [23, 30]


def test_splitter_gap_reads_3_from_old_checkpoints_and_refuses_less() -> None:
    assert NSRM2Config.from_dict({}).splitter_gap == 3
    assert NSRM2Config().splitter_gap == 5
    with pytest.raises(InvalidArgument, match=r"splitter_gap = 2.*at least 3"):
        NSRM2Config(splitter_gap=2)
    with pytest.raises(ValueError, match=r"gap must be at least its WINDOW \(3\).*got 1"):
        Splitter(10, gap=1)
    from nsrmp_bench.reference_model.program.ensemble import EnsembleSplitter

    with pytest.raises(ValueError, match=r"share one gap, got \[3, 5\]"):
        EnsembleSplitter([Splitter(10, gap=3), Splitter(10, gap=5)])


@pytest.mark.parametrize(("contiguous", "subject"), [(False, 1), (True, 0)])
def test_a_reference_ends_where_the_other_ones_head_begins(contiguous: bool,
                                                            subject: int) -> None:
    """"red left blue, go, red right blue": the red object left of the blue one (object
    0) is the subject. The parser is soft and swaps the relation words by a little (as
    the shipped one did on val): ``left`` reads 0.4 as the subject's relation and ``right``,
    inside the base's phrase, 0.6. Read as one sum the subject's relation is "right of",
    and the subject is object 1. With ``contiguous_references`` no word after the base's
    head began is the subject's relation, and the subject is object 0."""
    vocab = Vocabulary(("<pad>", "<unk>", "blue", "go", "left", "red", "right"))
    tokens, code, centres, mask, feats = _parsed_scene(
        vocab, ("red", "left", "blue", "go", "red", "right", "blue"),
        ((0, "subject", 1.0), (1, "subject-relation", 0.4), (1, "base-relation", 0.6),
         (2, "subject-anchor", 1.0), (3, "none", 1.0), (4, "base", 1.0),
         (5, "subject-relation", 0.6), (5, "base-relation", 0.4), (6, "base-anchor", 1.0)),
        (-0.2, 0.2, 0.0))
    idx = {w: i for i, w in enumerate(vocab.words)}
    model = _hand_model(vocab)
    model.cfg = NSRM2Config(concept_dim=4, contiguous_references=contiguous)
    with torch.no_grad():
        model.relation.weight[idx["right"]] = torch.tensor([20.0, 0.0, 0.0])
        model.relation_bias.weight[idx["right"]] = -1.5 * 20.0
    s_lp, _, _ = model.step(code, tokens, feats, centres, torch.zeros((1, 3)), mask)
    assert int(s_lp[0].argmax()) == subject
    assert NSRM2Config.from_dict({}).contiguous_references is False
