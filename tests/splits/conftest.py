"""One generated smoke-v2 split shared by the split tests (generation takes seconds)."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("pybullet")


@pytest.fixture(scope="session")
def smoke_dir(smoke_v2_root: Path) -> Path:
    """The session's smoke-v2 split root (tests/conftest.py)."""
    return smoke_v2_root
