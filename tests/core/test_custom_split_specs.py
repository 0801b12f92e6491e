"""Custom split specs from a file: the shipped specs' validation, named errors, no id clash."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.split_specs import load_split, load_split_file, resolve_split

SPEC: dict[str, Any] = {
    "id": "mine-v1",
    "description": "a custom split: 3-4 objects, one step",
    "image": [320, 240],
    "parts": {"train": {"count": 8, "entropy": 123456,
                        "strata": [{"objects": [3, 4], "steps": [1],
                                    "relational": ["none", "any"]}]}},
}


def write(tmp_path: Path, spec: dict[str, Any], name: str = "mine.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(spec), "utf-8")
    return path


def test_a_spec_file_is_an_unofficial_split(tmp_path: Path) -> None:
    spec = load_split_file(write(tmp_path, SPEC))
    assert spec.id == "mine-v1" and not spec.shipped and spec.source == str(tmp_path / "mine.json")
    assert spec.to_dict() == SPEC
    assert {spec.config("train", i).objects for i in range(8)} == {3, 4}
    assert resolve_split(str(tmp_path / "mine.json")) == spec
    assert resolve_split(_current()[0]).shipped


def _current() -> tuple[str, ...]:
    from nsrmp_bench.split_specs import list_splits

    return list_splits()


def test_a_file_repeating_a_shipped_spec_is_that_split(tmp_path: Path) -> None:
    shipped = _current()[0]
    spec = load_split(shipped)
    assert load_split_file(write(tmp_path, spec.to_dict())) == spec


def test_a_shipped_id_with_other_content_is_refused(tmp_path: Path) -> None:
    other = {**load_split(_current()[0]).to_dict(), "description": "changed"}
    with pytest.raises(InvalidArgument, match=r"is a shipped split but the spec differs.*own id"):
        load_split_file(write(tmp_path, other))


@pytest.mark.parametrize(("change", "message"), [
    ({"id": "Mine_1"}, r"'id' is 'Mine_1'; a split id is name-vN"),
    ({"parts": {}}, r"'parts' must map part names"),
    ({"parts": {"train": {"count": 8, "strata": []}}}, r"parts.train: a part needs 'count'"),
    ({"parts": {"train": {"count": 0, "entropy": 1, "strata": [{"objects": [3], "steps": [1]}]}}},
     r"count is 0"),
    ({"parts": {"train": {"count": 4, "entropy": -1, "strata": [{"objects": [3], "steps": [1]}]}}},
     r"entropy is -1; expected a non-negative integer"),
    ({"parts": {"train": {"count": 4, "entropy": 1, "strata": [{"objects": [2, 16], "steps": [1]}]}}},
     r"parts.train.strata\[0\].objects\[0\]: 2; expected a number of objects in 3\.\.15"),
    ({"parts": {"train": {"count": 4, "entropy": 1,
                          "strata": [{"objects": [3], "steps": [1], "phrasing": ["poetic"]}]}}},
     r"parts.train.strata\[0\].phrasing\[0\]: 'poetic'; expected one of"),
    ({"parts": {"train": {"count": 4, "entropy": 1, "strata": [{"objects": [3], "step": [1]}]}}},
     r"unknown keys \['step'\]"),
])
def test_a_bad_spec_file_names_the_value_and_the_fix(tmp_path: Path, change: dict[str, Any],
                                                      message: str) -> None:
    with pytest.raises(InvalidArgument, match=message):
        load_split_file(write(tmp_path, {**SPEC, **change}))


def test_an_unreadable_spec_file_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(InvalidArgument, match=r"does not exist; pass a split id or a spec file"):
        load_split_file(tmp_path / "nope.json")
    (tmp_path / "bad.json").write_text("{", "utf-8")
    with pytest.raises(InvalidArgument, match=r"is not readable JSON"):
        load_split_file(tmp_path / "bad.json")
    missing = {k: v for k, v in SPEC.items() if k != "image"}
    with pytest.raises(InvalidArgument, match=r"missing keys \['image'\]"):
        load_split_file(write(tmp_path, missing))
