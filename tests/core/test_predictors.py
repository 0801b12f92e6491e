"""One registry of predictors: the learned models and the baselines share it with their
kinds, ids are unique across both, and the closed loop's policies follow from the kinds (a
model registered from outside is a policy with no other line). The retired v1 models stay
registered with their kind, description and label, but nothing runs them: every verb that
would says which release has their code, and a bare name means the latest version."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

import nsrmp_bench.baselines  # noqa: F401  (registers the baselines)
from nsrmp_bench.cli.main import main
from nsrmp_bench.errors import InvalidArgument, UnknownId
from nsrmp_bench.predictors import PREDICTORS, Kind, RetiredPredictor, get_predictor, predictors
from nsrmp_bench.reference_model.registry import MODELS, ModelEntry, get_model, register

RETIRED = {"nsrm-v1": "nsrm-v4", "nmn-v1": "nmn-v4", "dense-v1": "dense-v2",
           "dense5x-v1": "dense5x-v2"}
"""The retired v1 models and the version that replaces each."""


def test_models_and_baselines_are_one_registry_with_their_kinds() -> None:
    assert {p.id for p in predictors(Kind.BASELINE)} == {"oracle-v1", "noop-v1", "random-v1"}
    assert get_predictor("nsrm").kind is Kind.PROGRAM
    assert get_predictor("dense-v2").kind is Kind.DENSE
    assert get_predictor("oracle").kind is Kind.BASELINE
    assert set(MODELS) <= set(PREDICTORS)
    with pytest.raises(UnknownId, match=r"unknown dense predictor 'nsrm-v2'"):
        get_predictor("nsrm-v2", Kind.DENSE)


def test_an_id_is_registered_once_across_models_and_baselines() -> None:
    with pytest.raises(InvalidArgument, match=r"'oracle-v1' is registered already.*new id"):
        register(ModelEntry("oracle-v1", Kind.PROGRAM, "a clash", "x:Y"))
    with pytest.raises(InvalidArgument, match=r"kind baseline"):
        register(ModelEntry("mine-v1", Kind.BASELINE, "not learned", "x:Y"))


@pytest.fixture
def outside() -> Iterator[ModelEntry]:
    entry = register(ModelEntry("outside-v1", Kind.DENSE, "registered from outside",
                                "my_pkg:Model"))
    yield entry
    PREDICTORS.pop(entry.id)
    MODELS.pop(entry.id)


def test_policies_follow_from_the_kind(outside: ModelEntry) -> None:
    pytest.importorskip("gymnasium")
    from nsrmp_bench.envs.policies import (
        check_policy,
        policy_names,
        reads_boxes,
        reads_gold_boxes,
    )

    names = policy_names()
    for name in ("oracle", "noop", "random", "nsrm", "nsrm-v2", "nmn", "dense", "dense5x-v2",
                 "outside", "outside-v1"):
        assert name in names, name
    assert "detector-v1" not in names and "reconstruction" not in names
    assert not set(RETIRED) & set(names)
    assert reads_gold_boxes("nsrm") and not reads_gold_boxes("outside")
    assert reads_boxes("outside") and not reads_boxes("oracle")
    with pytest.raises(InvalidArgument, match=r"unknown policy 'detector'.*module:function"):
        check_policy("detector")


def test_retired_models_keep_their_facts_but_are_not_runnable() -> None:
    retired = {p.id: p for p in predictors(retired=True)}
    assert set(retired) == set(RETIRED)
    assert all(isinstance(p, RetiredPredictor) for p in retired.values())
    assert retired["nsrm-v1"].kind is Kind.PROGRAM and retired["nmn-v1"].kind is Kind.PROGRAM
    assert retired["dense-v1"].kind is Kind.DENSE and retired["dense-v1"].label == "not CLIPort"
    assert retired["dense5x-v1"].label == "not CLIPort, 5x data"
    assert all(p.description and p.release == "0.2.0" for p in retired.values())
    assert all(PREDICTORS[i] is p for i, p in retired.items())
    assert not set(RETIRED) & set(MODELS)
    assert not set(RETIRED) & {p.id for p in predictors()}
    for old, new in RETIRED.items():  # the bare name means the latest version
        name = old.rsplit("-v", 1)[0]
        assert get_model(name).id == new and get_predictor(name).id == new
        assert retired[old].successor == new
        for lookup in (get_model, get_predictor):
            with pytest.raises(InvalidArgument, match=rf"{old} was retired after nsrmp-bench "
                               rf"0\.2\.0.*==0\.2\.0.*current version is {new}"):
                lookup(old)
    with pytest.raises(InvalidArgument, match=r"'nsrm-v1' is registered already"):
        register(ModelEntry("nsrm-v1", Kind.PROGRAM, "a new model on an old id", "x:Y"))


@pytest.mark.parametrize("verb", ["predict", "train", "rollout", "evaluate", "robustness"])
def test_every_verb_that_runs_a_model_says_which_release_has_a_retired_one(
        verb: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = {"predict": "nsrm-v1", "train": "nmn-v1", "rollout": "dense-v1",
             "evaluate": "dense5x-v1", "robustness": "nsrm-v1"}[verb]
    data, out = tmp_path / "data", tmp_path / "out"
    data.mkdir()
    args = {"predict": ["--data", data, "--out", out / "p.jsonl"],
            "train": ["--data", data, "--out", out],
            "rollout": ["--data", data, "--out", out / "p.jsonl"],
            "evaluate": ["--data-root", data, "--out", out],
            "robustness": ["--data", data, "--out", out]}[verb]
    assert main([verb, model, *map(str, args)]) == 2
    err = capsys.readouterr().err
    expected = (f"{model} was retired after nsrmp-bench 0.2.0, the last release with its code "
                'and checkpoint (pip install "nsrmp-bench[torch]==0.2.0" runs it); its '
                "committed predictions, model card and board rows stay. The current version "
                f"is {RETIRED[model]}: pass {RETIRED[model]} (or {model.rsplit('-v', 1)[0]}) "
                "instead")
    assert expected in err, err
    assert not out.exists()  # refused before anything is written


def test_load_model_of_a_retired_id_names_the_release() -> None:
    import nsrmp_bench

    with pytest.raises(InvalidArgument, match=r"nsrm-v1 was retired.*nsrmp-bench\[torch\]==0\.2\.0"):
        nsrmp_bench.load_model("nsrm-v1")
