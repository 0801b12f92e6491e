"""Data every test directory may need, generated on the fly once per session."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def smoke_v2_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """smoke-v2 (16 rendered episodes in test/), generated here with the official shard
    size; skips without PyBullet. Tests must not write into it."""
    pytest.importorskip("pybullet")
    from nsrmp_bench.generators.generate import generate_split

    out = tmp_path_factory.mktemp("smoke-v2")
    generate_split("smoke-v2", out, workers=2)
    return out


@pytest.fixture(scope="session")
def smoke_v2_test(smoke_v2_root: Path) -> Path:
    """The part directory smoke-v2/test of :func:`smoke_v2_root`."""
    return smoke_v2_root / "test"
