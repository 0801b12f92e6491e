"""A tiny paper-v2 split (train and val, first instances only) generated once for the
model tests, and smoke-v2/test."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("torch")

TRAIN, VAL = 320, 48


@pytest.fixture(scope="session")
def tiny_paper(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from nsrmp_bench.generators.generate import generate_part
    from nsrmp_bench.split_specs import load_split

    out = tmp_path_factory.mktemp("tiny-paper")
    spec = load_split("paper-v2")
    generate_part(spec, "train", out / "train", workers=2, limit=TRAIN)
    generate_part(spec, "val", out / "val", workers=2, limit=VAL)
    return out


@pytest.fixture(scope="session")
def smoke_test(smoke_v2_test: Path) -> Path:
    """smoke-v2/test (the session's, from tests/conftest.py)."""
    return smoke_v2_test


@pytest.fixture(scope="session")
def iou_m_of() -> Callable[[Path, Path, Path], float]:
    """The public scorer's headline IoU-M of a predictions file on a data part."""
    from nsrmp_bench.cli.main import main

    def score(pred: Path, data: Path, tmp: Path) -> float:
        out = tmp / (pred.stem + ".scores.json")
        assert main(["score", str(pred), "--data", str(data), "--json", str(out), "--quiet",
                     "--n-boot", "0"]) == 0
        return float(json.loads(out.read_text())["summary"]["iou_m"]["value"])

    return score


class _Forbidden(dict):  # type: ignore[type-arg]
    def __getitem__(self, key: object) -> Any:
        msg = f"the model read targets[{key!r}]"
        raise AssertionError(msg)

    def get(self, key: object, default: Any = None) -> Any:
        return self[key]


@pytest.fixture(scope="session")
def hide_targets() -> Callable[[dict[str, Any]], dict[str, Any]]:
    """A dataset transform whose items' targets fail the test when read."""
    def hide(item: dict[str, Any]) -> dict[str, Any]:
        return {**item, "targets": _Forbidden()}

    return hide
