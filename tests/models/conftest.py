"""A tiny paper-v2 split (train and val, first instances only) generated once for the
model tests, and smoke-v2/test."""

from __future__ import annotations

from pathlib import Path

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
def smoke_test(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from nsrmp_bench.generators.generate import generate_split

    out = tmp_path_factory.mktemp("smoke-models")
    generate_split("smoke-v2", out, workers=2)
    return out / "test"
