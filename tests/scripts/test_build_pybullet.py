"""``scripts/build_pybullet.py``: the pinned sdist, the patches and each step's errors.

Building the wheel takes about 5 minutes on 2 cores, so the tests stop short of it: they
apply the real patches to the real sdist (downloaded from the package registry, as the
script does) and check every refusal. The patched build's bytes are proven by regenerating
every committed part with it (README, "Generation speed").
"""

from __future__ import annotations

import difflib
import io
import subprocess
import sys
import tarfile
from pathlib import Path
from types import ModuleType

import pytest
from script_module import SCRIPTS, load_script

SCRIPT = SCRIPTS / "build_pybullet.py"


@pytest.fixture(scope="module")
def bp() -> ModuleType:
    return load_script("build_pybullet")


@pytest.fixture(scope="module")
def sdist(bp: ModuleType, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The pinned sdist, fetched from the registry the way the script fetches it (a
    machine that cannot reach the registry skips the test that needs it; a file that is
    not the pinned one still fails it)."""
    try:
        return bp.fetch_sdist(tmp_path_factory.mktemp("sdist"))  # type: ignore[no-any-return]
    except bp.BuildError as exc:
        pytest.skip(f"the package registry is out of reach: {exc}")


def _tarball(path: Path, files: dict[str, str]) -> Path:
    with tarfile.open(path, "w:gz") as tar:
        for name, text in files.items():
            data = text.encode()
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    return path


def _patch(rel: str, before: str, after: str) -> str:
    return "".join(difflib.unified_diff(before.splitlines(keepends=True),
                                        after.splitlines(keepends=True),
                                        fromfile=f"a/{rel}", tofile=f"b/{rel}"))


@pytest.mark.slow
def test_the_pinned_sdist_gets_the_patches_and_the_local_version(
    bp: ModuleType, sdist: Path, tmp_path: Path
) -> None:
    bp.check_sdist(sdist)
    root = bp.unpack(sdist, tmp_path)
    before = {p: (root / p).read_text() for p in (
        "src/LinearMath/btPoolAllocator.h", "src/LinearMath/btAlignedAllocator.cpp",
        "src/LinearMath/btSerializer.h", "Extras/Serialize/BulletFileLoader/bFile.cpp")}
    bp.apply_patches(root, bp.patches())
    bp.set_version(root)
    for rel, text in before.items():
        changed = (root / rel).read_text()
        assert changed != text and "nsrmp" in changed, rel
    assert "version='3.2.7+nsrmp.2'" in (root / "setup.py").read_text()
    # applied twice, a patch is refused by name rather than applied backwards
    with pytest.raises(bp.BuildError, match=r"0001-.*\.patch does not apply"):
        bp.apply_patches(root, bp.patches()[:1])


def test_the_patches_come_in_order_and_change_only_bullet_sources(bp: ModuleType) -> None:
    files = bp.patches()
    assert [p.name[:4] for p in files] == sorted(p.name[:4] for p in files)
    for p in files:
        text = p.read_text()
        targets = [line.split()[1] for line in text.splitlines() if line.startswith("+++ ")]
        assert targets, p.name
        # Bullet's own sources and the third-party loaders PyBullet bundles (tinyobj)
        allowed = ("b/src/", "b/Extras/", "b/examples/ThirdPartyLibs/")
        assert all(t.startswith(allowed) for t in targets), (p.name, targets)


def test_an_sdist_other_than_the_pinned_one_is_refused_naming_both_hashes(
    bp: ModuleType, tmp_path: Path
) -> None:
    other = _tarball(tmp_path / "pybullet-3.2.7.tar.gz", {"pybullet-3.2.7/setup.py": "x"})
    with pytest.raises(bp.BuildError, match=rf"has sha256 [0-9a-f]{{64}}.*{bp.SDIST_SHA256}"):
        bp.check_sdist(other)
    with pytest.raises(bp.BuildError, match="does not exist"):
        bp.check_sdist(tmp_path / "missing.tar.gz")


def test_a_tarball_without_the_pybullet_tree_is_refused(bp: ModuleType, tmp_path: Path) -> None:
    other = _tarball(tmp_path / "x.tar.gz", {"other/setup.py": "x"})
    with pytest.raises(bp.BuildError, match=r"no pybullet-3\.2\.7/setup\.py"):
        bp.unpack(other, tmp_path / "out")


def test_a_patch_applies_to_its_tree_and_one_that_does_not_is_named(
    bp: ModuleType, tmp_path: Path
) -> None:
    tree = tmp_path / "tree"
    (tree / "src").mkdir(parents=True)
    (tree / "src" / "a.h").write_text("int a;\nint b;\nint c;\n")
    good = tmp_path / "0001-good.patch"
    good.write_text(_patch("src/a.h", "int a;\nint b;\nint c;\n", "int a;\nint bb;\nint c;\n"))
    bad = tmp_path / "0002-bad.patch"
    bad.write_text(_patch("src/a.h", "int x;\nint y;\n", "int x;\nint z;\n"))
    bp.apply_patches(tree, [good])
    assert (tree / "src" / "a.h").read_text() == "int a;\nint bb;\nint c;\n"
    with pytest.raises(bp.BuildError, match=r"0002-bad\.patch does not apply"):
        bp.apply_patches(tree, [bad])
    with pytest.raises(bp.BuildError, match=r"no \*\.patch files"):
        bp.patches(tmp_path / "tree")


def test_the_version_is_set_once_or_refused(bp: ModuleType, tmp_path: Path) -> None:
    (tmp_path / "setup.py").write_text("setup(\n    version='3.2.7',\n)\n")
    bp.set_version(tmp_path)
    assert "version='3.2.7+nsrmp.2'" in (tmp_path / "setup.py").read_text()
    with pytest.raises(bp.BuildError, match=r"does not set version='3\.2\.7' exactly once"):
        bp.set_version(tmp_path)


def test_the_command_line_reports_a_refusal_and_exits_1(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, str(SCRIPT), "--sdist", str(tmp_path / "no.tar.gz")],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 1
    assert "error:" in done.stderr and "does not exist" in done.stderr
