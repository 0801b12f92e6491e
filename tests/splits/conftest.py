"""One generated smoke-v2 split shared by the split tests (generation takes seconds)."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("pybullet")


@pytest.fixture(scope="session")
def smoke_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from nsrmp_bench.generators.generate import generate_split

    out = tmp_path_factory.mktemp("smoke")
    generate_split("smoke-v2", out, workers=2)  # the official shard size
    return out
