"""Split specs: every official spec loads, balances its grid, and changes one axis."""

from __future__ import annotations

import json
from collections import Counter
from importlib import resources

import pytest

from nsrmp_bench.errors import UnknownId
from nsrmp_bench.split_specs import OFFICIAL_SPLITS, list_splits, load_split


def test_every_shipped_spec_loads_and_ids_match() -> None:
    for sid in list_splits():
        spec = load_split(sid)
        assert spec.id == sid
        for part, ps in spec.parts.items():
            assert spec.config(part, 0) is not None
            assert spec.config(part, ps.count - 1) is not None


def test_official_set_is_shipped() -> None:
    shipped = set(list_splits())
    missing = [s for s in OFFICIAL_SPLITS if s not in shipped]
    assert not missing


def test_entropies_are_unique_across_parts() -> None:
    seen = Counter(ps.entropy for sid in list_splits() for ps in load_split(sid).parts.values())
    assert max(seen.values()) == 1


def test_paper_is_balanced() -> None:
    spec = load_split("paper-v2")
    configs = [spec.config("test", i) for i in range(spec.parts["test"].count)]
    for axis in ("objects", "steps", "relational", "phrasing"):
        counts = Counter(getattr(c, axis) for c in configs)
        assert max(counts.values()) - min(counts.values()) <= 8, (axis, counts)


@pytest.mark.parametrize(
    ("split", "part", "axis"),
    [("objects-v2", "test", "objects"), ("steps-v2", "test", "steps"),
     ("attributes-v2", "test", "required_pairs"), ("attributes-v2", "train", "pairs"),
     ("language-v2", "test", "held_out")],
)
def test_ood_splits_change_one_axis(split: str, part: str, axis: str) -> None:
    paper = load_split("paper-v2")
    spec = load_split(split)
    fields = ("objects", "steps", "relational", "phrasing", "held_out", "pairs", "required_pairs")
    ours = {f: {getattr(spec.config(part, i), f) for i in range(spec.parts[part].count)}
            for f in fields}
    ref = {f: {getattr(paper.config("train", i), f) for i in range(360)} for f in fields}
    changed = [f for f in fields if ours[f] != ref[f]]
    assert changed == [axis]
    assert spec.changes


def test_unknown_split_names_close_matches_and_versions() -> None:
    with pytest.raises(UnknownId, match=r"did you mean 'paper-v2'"):
        load_split("papr-v1")
    with pytest.raises(UnknownId, match=r"versions of it that do: \['paper-v2'\]"):
        load_split("paper-v9")
    with pytest.raises(UnknownId, match=r"has no part 'train'; its parts are \['test'\]"):
        load_split("objects-v2").part("train")


def test_a_withdrawn_split_names_its_successor_and_why() -> None:
    assert "paper-v1" in list_splits(withdrawn=True)
    assert "paper-v1" not in list_splits()
    with pytest.raises(UnknownId, match=r"'paper-v1' was withdrawn: .*regenerate the committed bytes.*Use 'paper-v2'"):
        load_split("paper-v1")
    successor = load_split("paper-v2").to_dict()
    assert successor["supersedes"]["id"] == "paper-v1"
    old = dict(json.loads((resources.files("nsrmp_bench.splits") / "paper-v1.json")
                          .read_text("utf-8")))
    same = {k: v for k, v in successor.items() if k not in ("id", "supersedes")}
    assert same == {k: v for k, v in old.items() if k not in ("id", "withdrawn")}
