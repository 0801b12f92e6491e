"""A custom split from a spec file, end to end: generate (1 and 2 workers, same root hash),
an unofficial manifest holding the spec, verify and info against it; and no PyBullet banner
in the output of `generate` (driver and workers) or `sample --render`."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.sim

SPEC = {
    "id": "custom-v1",
    "description": "a custom split for the tests: 3-4 objects, one or two steps",
    "image": [160, 120],
    "parts": {"test": {"count": 6, "entropy": 5150,
                       "strata": [{"objects": [3, 4], "steps": [1, 2],
                                   "relational": ["none", "any"]}]}},
}
BANNER = "pybullet build time"


def nsrmp(*args: str | Path) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, "-m", "nsrmp_bench.cli.main", *map(str, args)]
    return subprocess.run(cmd, capture_output=True, text=True, check=False)


def flat(text: str) -> str:
    """``text`` with rich's line wrapping undone."""
    return " ".join(text.split())


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path, str]:
    tmp = tmp_path_factory.mktemp("custom")
    spec = tmp / "custom.json"
    spec.write_text(json.dumps(SPEC), "utf-8")
    one = nsrmp("generate", "--spec", spec, "--out", tmp / "one", "--workers", "1",
                "--shard-size", "2", "--quiet")
    two = nsrmp("generate", "--split", spec, "--out", tmp / "two", "--workers", "2",
                "--shard-size", "3", "--quiet")
    assert one.returncode == 0, one.stderr
    assert two.returncode == 0, two.stderr
    return spec, tmp / "one", tmp / "two", one.stdout + one.stderr + two.stdout + two.stderr


def test_one_and_two_workers_give_the_same_root_hash(
        generated: tuple[Path, Path, Path, str]) -> None:
    _, one, two, output = generated
    a = json.loads((one / "test" / "manifest.json").read_text())
    b = json.loads((two / "test" / "manifest.json").read_text())
    assert a["root_hash"] == b["root_hash"] and len(a["shards"]) == 3 and len(b["shards"]) == 2
    assert a["split"] == "custom-v1/test" and a["counts"]["episodes"] == 6
    assert "unofficial split" in output and "no committed manifest" in flat(output)


def test_the_manifest_says_unofficial_and_holds_the_spec(
        generated: tuple[Path, Path, Path, str]) -> None:
    _, one, _, _ = generated
    manifest = json.loads((one / "test" / "manifest.json").read_text())
    assert manifest["official"] is False and manifest["spec"] == SPEC


def test_verify_and_info_take_the_spec(generated: tuple[Path, Path, Path, str],
                                       tmp_path: Path) -> None:
    spec, one, _, _ = generated
    ok = nsrmp("verify", one, "--spec", spec)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    assert "OK" in ok.stdout and "unofficial split custom-v1/test" in flat(ok.stdout)
    other = tmp_path / "other.json"
    other.write_text(json.dumps({**SPEC, "description": "another"}), "utf-8")
    bad = nsrmp("verify", one, "--spec", other)
    assert bad.returncode == 1 and "differs from" in bad.stdout
    info = nsrmp("info", "--spec", spec)
    assert info.returncode == 0
    assert "6 instances (unofficial split custom-v1)" in flat(info.stdout)
    assert "6 instances" in nsrmp("info", one / "test").stdout


def test_no_pybullet_banner_in_generate_or_sample(generated: tuple[Path, Path, Path, str],
                                                  tmp_path: Path) -> None:
    assert BANNER not in generated[3]
    sample = nsrmp("sample", "--seed", "7", "--objects", "3", "--steps", "1",
                   "--render", tmp_path / "out")
    assert sample.returncode == 0, sample.stderr
    assert BANNER not in sample.stdout + sample.stderr
