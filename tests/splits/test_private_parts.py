"""Private parts end to end: a spec whose test entropy is a secret is generated with the
secret from a file and from the environment (same bytes), the secret and its derived
entropy appear in no file written, the manifest's commitment opens with the revealed
secret and fails with a wrong one, another secret gives other data, a resume with another
secret is refused, and a private part without its secret is refused before any work."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.private_parts import (
    SECRET_ENV,
    commitment,
    derived_entropy,
    read_secret,
)
from nsrmp_bench.split_specs import load_split_file
from nsrmp_bench.storage.manifest import read_manifest
from nsrmp_bench.storage.reader import open as open_data
from nsrmp_bench.verify import verify

pytestmark = pytest.mark.sim

SECRET = "9f1c2e7a4b6d8e0f1a3c5e7b9d2f4a6c8e0b2d4f6a8c0e2b4d6f8a0c2e4b6d8f"
OTHER = "c1191609540a00df58cc5be8072fe76d6b1cbb3e21d7c7cbbb6836bd389d3aa2"
SPEC = {
    "id": "hidden-v1",
    "description": "a private test part for the tests: 3-4 objects, one or two steps",
    "image": [160, 120],
    "parts": {
        "train": {"count": 2, "entropy": 77,
                  "strata": [{"objects": [3], "steps": [1]}]},
        "test": {"count": 3, "entropy": "secret",
                 "strata": [{"objects": [3, 4], "steps": [1, 2]}]},
    },
}


def nsrmp(*args: str | Path, env: dict[str, str] | None = None
          ) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, "-m", "nsrmp_bench.cli.main", *map(str, args)]
    full = {k: v for k, v in os.environ.items() if k != SECRET_ENV}
    full.update(env or {})
    return subprocess.run(cmd, capture_output=True, text=True, check=False, env=full)


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path, Path]:
    tmp = tmp_path_factory.mktemp("private")
    spec = tmp / "hidden.json"
    spec.write_text(json.dumps(SPEC), "utf-8")
    secret = tmp / "secret.txt"
    secret.write_text(SECRET + "\n", "utf-8")
    by_file = nsrmp("generate", "--spec", spec, "--out", tmp / "file", "--workers", "1",
                    "--part", "test", "--secret-file", secret, "--quiet")
    assert by_file.returncode == 0, by_file.stderr
    assert "commitment" in by_file.stdout + by_file.stderr
    by_env = nsrmp("generate", "--spec", spec, "--out", tmp / "env", "--workers", "1",
                   "--shard-size", "2", "--quiet", env={SECRET_ENV: SECRET})
    assert by_env.returncode == 0, by_env.stderr
    other = tmp / "other.txt"
    other.write_text(OTHER, "utf-8")
    by_other = nsrmp("generate", "--spec", spec, "--out", tmp / "other", "--workers", "1",
                     "--part", "test", "--secret-file", other, "--quiet")
    assert by_other.returncode == 0, by_other.stderr
    return spec, tmp / "file" / "test", tmp / "env", tmp / "other" / "test"


def test_the_secret_gives_the_same_data_from_a_file_or_the_environment(
        made: tuple[Path, Path, Path, Path]) -> None:
    _, by_file, by_env, by_other = made
    a, b = read_manifest(by_file), read_manifest(by_env / "test")
    assert a.root_hash == b.root_hash and a.count == 3
    assert a.private == b.private and a.private is not None
    assert a.private["commitment"] == commitment(SPEC, "test", SECRET)
    assert read_manifest(by_other).root_hash != a.root_hash  # the secret is the entropy
    assert read_manifest(by_env / "train").private is None  # the public part stays public


def test_neither_the_secret_nor_its_entropy_is_written(
        made: tuple[Path, Path, Path, Path]) -> None:
    _, by_file, by_env, _ = made
    entropy = str(derived_entropy(SECRET, "hidden-v1", "test")).encode()
    for path in [*by_file.rglob("*"), *by_env.rglob("*")]:
        if path.is_file():
            data = path.read_bytes()
            assert SECRET.encode() not in data and entropy not in data, path
    with open_data(by_file) as data:
        seed = data[0].symbolic.seed
    assert seed.sealed and seed.index == 0
    with pytest.raises(InvalidArgument, match="sealed"):
        seed.generator()


def test_the_revealed_secret_opens_the_commitment_and_a_wrong_one_does_not(
        made: tuple[Path, Path, Path, Path], tmp_path: Path) -> None:
    spec_file, by_file, _, _ = made
    spec = load_split_file(spec_file)
    sealed = verify(by_file, spec=spec)
    assert sealed.ok and any("private part" in n for n in sealed.notes)
    opened = verify(by_file, spec=spec, secret=SECRET)
    assert opened.ok and any("opens the manifest's commitment" in n for n in opened.notes)
    wrong = verify(by_file, spec=spec, secret=OTHER)
    assert not wrong.ok and "does not open the manifest's commitment" in wrong.problems[0]
    revealed = tmp_path / "revealed.txt"
    revealed.write_text(OTHER, "utf-8")
    out = nsrmp("verify", by_file, "--secret-file", revealed)
    assert out.returncode == 1 and "does not open" in " ".join(out.stdout.split())
    revealed.write_text(SECRET, "utf-8")
    out = nsrmp("verify", by_file, "--secret-file", revealed)
    assert out.returncode == 0, out.stdout


def test_a_private_part_without_its_secret_is_refused_before_any_work(
        made: tuple[Path, Path, Path, Path], tmp_path: Path) -> None:
    spec_file = made[0]
    out = nsrmp("generate", "--spec", spec_file, "--out", tmp_path / "x", "--part", "test")
    assert out.returncode != 0
    said = " ".join(out.stderr.split())
    assert "is private" in said and "--secret-file" in said and SECRET_ENV in said
    assert not (tmp_path / "x").exists() or not any((tmp_path / "x").rglob("*.h5"))


def test_a_resume_with_another_secret_is_refused(
        made: tuple[Path, Path, Path, Path], tmp_path: Path) -> None:
    from nsrmp_bench.generators.generate import generate_part

    spec = load_split_file(made[0])
    out = tmp_path / "part"
    generate_part(spec, "test", out, workers=1, limit=1, secret=SECRET)
    with pytest.raises(InvalidArgument, match="another secret"):
        generate_part(spec, "test", out, workers=1, limit=1, secret=OTHER)


def test_a_short_secret_is_refused_with_the_fix(tmp_path: Path) -> None:
    short = tmp_path / "short.txt"
    short.write_text("hunter2", "utf-8")
    with pytest.raises(InvalidArgument, match="needs at least 32"):
        read_secret(short)
    with pytest.raises(InvalidArgument, match="needs at least 32"):
        read_secret(None, {SECRET_ENV: "abc"})
    assert read_secret(None, {}) is None
    assert read_secret(None, {SECRET_ENV: SECRET}) == SECRET
