"""A PyBullet world shared by the robot tests (building one loads URDFs: ~0.2 s)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest


@pytest.fixture(scope="session")
def world() -> Iterator[Any]:
    pytest.importorskip("pybullet")
    pytest.importorskip("cv2")
    from nsrmp_bench.generators.world.world import World

    with World() as w:
        yield w
