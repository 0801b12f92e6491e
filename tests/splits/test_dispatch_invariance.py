"""Generation does not depend on which SIMD / BLAS kernels the CPU gets.

Two subprocesses generate a small mixed part, one with numpy's and OpenBLAS's default
dispatch, one with every numpy dispatch target disabled (``NPY_DISABLE_CPU_FEATURES``, only
the baseline left), OpenBLAS forced to a pre-AVX core (``OPENBLAS_CORETYPE=Nehalem``) and
OpenCV's optional SIMD paths off (``OPENCV_CPU_DISABLE``):
teleport episodes (smoke-v2: 3-15 objects, 1-7 steps) must give equal root hashes, equal to
the committed one; robot episodes (the first of robot-v2) must agree within the tolerances
the manifest states. Runs on any x86-64 machine in about 30 s.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

from nsrmp_bench.dispatch import lowest_dispatch_env
from nsrmp_bench.official_manifests import official_manifest
from nsrmp_bench.verify import compare_with_committed

pytestmark = [
    pytest.mark.sim,
    pytest.mark.slow,
    pytest.mark.skipif(platform.machine().lower() not in {"x86_64", "amd64"},
                       reason="NPY_DISABLE_CPU_FEATURES/OPENBLAS_CORETYPE names are x86 ones"),
]

ROBOT_EPISODES = 3
_SCRIPT = """
import sys
from nsrmp_bench.generators.generate import generate_part
from nsrmp_bench.split_specs import load_split
out = sys.argv[1]
generate_part(load_split("smoke-v2"), "test", out + "/smoke", workers=1)
generate_part(load_split("robot-v2"), "test", out + "/robot", workers=1, limit=int(sys.argv[2]))
"""


def _generate(out: Path, extra_env: dict[str, str]) -> tuple[dict, dict]:
    env = {k: v for k, v in os.environ.items()
           if k not in ("NPY_DISABLE_CPU_FEATURES", "NPY_ENABLE_CPU_FEATURES",
                        "OPENBLAS_CORETYPE", "OPENCV_CPU_DISABLE")}
    env.update(extra_env)
    subprocess.run([sys.executable, "-c", _SCRIPT, str(out), str(ROBOT_EPISODES)],
                   env=env, check=True, timeout=300)
    return (json.loads((out / "smoke" / "manifest.json").read_text()),
            json.loads((out / "robot" / "manifest.json").read_text()))


@pytest.fixture(scope="module")
def two_dispatches(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[dict, dict]]:
    root = tmp_path_factory.mktemp("dispatch")
    return {"default": _generate(root / "default", {}),
            "lowest": _generate(root / "lowest", lowest_dispatch_env())}


def test_the_settings_really_differ(two_dispatches: dict[str, tuple[dict, dict]]) -> None:
    low = two_dispatches["lowest"][0]["versions"]
    assert low["numpy_simd"].endswith("dispatch none")
    assert low["blas"] in ("OpenBLAS Nehalem", "unknown")
    assert two_dispatches["default"][0]["versions"]["numpy_simd"] != low["numpy_simd"] or \
        low["numpy_simd"] == "unknown"


def test_teleport_bytes_do_not_depend_on_dispatch(
    two_dispatches: dict[str, tuple[dict, dict]],
) -> None:
    a, b = two_dispatches["default"][0], two_dispatches["lowest"][0]
    differ = [x["id"] for x, y in zip(a["episodes"], b["episodes"], strict=True)
              if x["hash"] != y["hash"]]
    assert not differ, f"teleport episodes depend on SIMD/BLAS dispatch: {differ}"
    assert a["root_hash"] == b["root_hash"]
    committed = official_manifest("smoke-v2", "test")
    assert committed is not None and committed["root_hash"] == a["root_hash"]


def test_robot_episodes_agree_within_the_stated_tolerances(
    two_dispatches: dict[str, tuple[dict, dict]],
) -> None:
    a, b = two_dispatches["default"][1], two_dispatches["lowest"][1]
    assert a["comparison"]["tolerant"]["tolerances"] == b["comparison"]["tolerant"]["tolerances"]
    local = {int(e["index"]): (e["hash"], e["tolerant"]) for e in b["episodes"]}
    cmp = compare_with_committed(local, a)
    assert cmp.ok, cmp.beyond_tolerance
    committed = official_manifest("robot-v2", "test")
    assert committed is not None
    against = compare_with_committed(local, committed)
    assert not against.differ_beyond, against.beyond_tolerance
