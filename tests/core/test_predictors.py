"""One registry of predictors: the learned models and the baselines share it with their
kinds, ids are unique across both, and the closed loop's policies follow from the kinds (a
model registered from outside is a policy with no other line)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

import nsrmp_bench.baselines  # noqa: F401  (registers the baselines)
from nsrmp_bench.errors import InvalidArgument, UnknownId
from nsrmp_bench.predictors import PREDICTORS, Kind, get_predictor, predictors
from nsrmp_bench.reference_model.registry import MODELS, ModelEntry, register


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
    for name in ("oracle", "noop", "random", "nsrm", "nsrm-v2", "nmn", "dense", "dense5x-v1",
                 "outside", "outside-v1"):
        assert name in names, name
    assert "detector-v1" not in names and "reconstruction" not in names
    assert reads_gold_boxes("nsrm") and not reads_gold_boxes("outside")
    assert reads_boxes("outside") and not reads_boxes("oracle")
    with pytest.raises(InvalidArgument, match=r"unknown policy 'detector'.*module:function"):
        check_policy("detector")
