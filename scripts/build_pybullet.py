"""Build PyBullet 3.2.7 with nsrmp-bench's speed patches: an optional wheel, the same bytes.

Most of what is left of an instance's reset (``World.begin``, ``docs/performance.md``)
is spent inside PyBullet on work whose results nothing reads: zeroing and linking two pools
of 4,096 contact manifolds and collision algorithms that every ``resetSimulation`` builds
afresh (and zeroing every aligned block twice), parsing the same two DNA tables again
for every body the client is told about, and parsing the same meshes and computing the
same hulls for every instance. The patches in ``scripts/pybullet/`` remove that work and
nothing else:

- ``0001``: a pool hands each element out zeroed and linked, as its eager constructor left
  it, but zeroes it when it is first handed out instead of all of them up front;
- ``0002``: an aligned block is zeroed once, not twice (the same zero bytes handed out);
- ``0003``: the client keeps a (file DNA, memory DNA) pair it parsed, from its own copies
  of the bytes, and reuses it while both buffers hold the same bytes (compared in full);
- ``0004``: the server's serializer parses each memory DNA once per process;
- ``0005``: an ``.obj`` mesh's parse is kept per (file name, base path, the file's bytes)
  and handed out again while the file holds the same bytes (compared in full): the URDF
  import parsed the arm's collision meshes again for every instance;
- ``0006``: a convex hull's vertices are kept per list of input points (compared byte for
  byte) and handed out again, instead of computing the same hull for every instance.

Every committed v2 part regenerates bit for bit with the patched build
(``docs/performance.md``). The
script downloads the pinned sdist from the package registry (or takes ``--sdist``), checks
its sha256, applies the patches, and builds a wheel versioned ``3.2.7+nsrmp.2`` with this
interpreter's numpy (about 5 minutes on 2 cores; POSIX: the pool patch uses
``posix_memalign``)::

    python scripts/build_pybullet.py --install

``--install`` replaces the environment's PyBullet with the wheel; ``pip install
pybullet==3.2.7`` goes back. Manifests record the version in use.
"""

from __future__ import annotations

import argparse
import importlib.util
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

from nsrmp_bench.canonical import sha256_file

PATCHES = Path(__file__).resolve().parent / "pybullet"
VERSION = "3.2.7"
LOCAL_VERSION = f"{VERSION}+nsrmp.2"
SDIST = f"pybullet-{VERSION}.tar.gz"
SDIST_SHA256 = "042879db8d101ac7590dee475fc6aded508b85fe1273fdbbfde1d88bd200e14f"
"""sha256 of the registry's ``pybullet-3.2.7.tar.gz`` (the sdist the patches are made for)."""


class BuildError(RuntimeError):
    """A step of the build failed; the message names it and what to do."""


def fetch_sdist(dest: Path) -> Path:
    """Download the pinned sdist from the package registry into ``dest`` (pip)."""
    cmd = [sys.executable, "-m", "pip", "download", f"pybullet=={VERSION}", "--no-binary",
           ":all:", "--no-deps", "--no-build-isolation", "-d", str(dest)]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    path = dest / SDIST
    if done.returncode != 0 or not path.is_file():
        msg = (f"could not download {SDIST} from the package registry ({' '.join(cmd)} "
               f"exited {done.returncode}: {done.stderr.strip()[-400:]}); download it and "
               "pass --sdist PATH")
        raise BuildError(msg)
    return path


def check_sdist(path: Path) -> None:
    """Refuse an sdist that is not the pinned one, naming both hashes."""
    if not path.is_file():
        msg = f"--sdist {path} does not exist; pass the path of {SDIST}"
        raise BuildError(msg)
    actual = sha256_file(path)
    if actual != SDIST_SHA256:
        msg = (f"{path} has sha256 {actual}, but the patches are made for {SDIST} with "
               f"sha256 {SDIST_SHA256}; pass that file (or leave --sdist out to download it)")
        raise BuildError(msg)


def unpack(sdist: Path, dest: Path) -> Path:
    """Extract ``sdist`` under ``dest``; returns its source root."""
    with tarfile.open(sdist) as tar:
        if hasattr(tarfile, "data_filter"):
            tar.extractall(dest, filter="data")
        else:  # pragma: no cover - Python without PEP 706's filters
            tar.extractall(dest)  # the sdist's sha256 was checked
    root = dest / f"pybullet-{VERSION}"
    if not (root / "setup.py").is_file():
        msg = f"{sdist} holds no pybullet-{VERSION}/setup.py; is it the PyBullet sdist?"
        raise BuildError(msg)
    return root


def patches(folder: Path = PATCHES) -> list[Path]:
    """The patch files, in the order they apply."""
    found = sorted(folder.glob("*.patch"))
    if not found:
        msg = f"no *.patch files in {folder}; the checkout is incomplete"
        raise BuildError(msg)
    return found


def apply_patches(root: Path, files: list[Path]) -> None:
    """Apply each patch (``patch -p1``) to the source tree at ``root``; a patch that does
    not apply cleanly stops the build, named."""
    if shutil.which("patch") is None:
        msg = "the `patch` program is missing; install it (Debian: apt-get install patch)"
        raise BuildError(msg)
    for p in files:
        done = subprocess.run(["patch", "-p1", "--forward", "--batch", "--quiet", "-i",
                               str(p)], cwd=root, capture_output=True, text=True,
                              check=False)
        if done.returncode != 0:
            msg = (f"{p.name} does not apply to {root.name}: "
                   f"{(done.stdout + done.stderr).strip()[-400:]}")
            raise BuildError(msg)


def set_version(root: Path) -> None:
    """Give the build the local version ``3.2.7+nsrmp.2``, so manifests tell it apart."""
    setup = root / "setup.py"
    text = setup.read_text()
    old = f"version='{VERSION}'"
    if text.count(old) != 1:
        msg = f"{setup} does not set {old} exactly once; is it the {SDIST} sdist?"
        raise BuildError(msg)
    setup.write_text(text.replace(old, f"version='{LOCAL_VERSION}'"))


def build_wheel(root: Path, out: Path) -> Path:
    """Build the wheel with this interpreter (its numpy: ``pybullet.isNumpyEnabled()``)."""
    for module in ("numpy", "setuptools"):
        if importlib.util.find_spec(module) is None:
            msg = (f"{module} is missing from this environment ({sys.executable}); the "
                   f"build uses it: pip install {module}")
            raise BuildError(msg)
    out.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "wheel", str(root), "--no-deps",
           "--no-build-isolation", "-w", str(out)]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wheels = sorted(out.glob(f"pybullet-{LOCAL_VERSION}-*.whl"))
    if done.returncode != 0 or not wheels:
        msg = (f"building the wheel failed ({' '.join(cmd)} exited {done.returncode}): "
               f"{(done.stdout + done.stderr).strip()[-800:]}")
        raise BuildError(msg)
    return wheels[-1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sdist", type=Path, default=None,
                        help=f"a local {SDIST} (default: download it from the registry)")
    parser.add_argument("--out", type=Path, default=Path("dist"),
                        help="folder for the wheel (default: dist)")
    parser.add_argument("--install", action="store_true",
                        help="install the wheel into this environment (replaces PyBullet)")
    args = parser.parse_args(argv)
    try:
        with tempfile.TemporaryDirectory(prefix="nsrmp-pybullet-") as tmp:
            work = Path(tmp)
            sdist = args.sdist if args.sdist is not None else fetch_sdist(work)
            check_sdist(sdist)
            root = unpack(sdist, work / "src")
            apply_patches(root, patches())
            set_version(root)
            print(f"building {LOCAL_VERSION} (about 5 minutes on 2 cores) ...", flush=True)
            wheel = build_wheel(root, args.out)
        print(f"built {wheel}")
        if args.install:
            cmd = [sys.executable, "-m", "pip", "install", "--force-reinstall", "--no-deps",
                   str(wheel)]
            if subprocess.run(cmd, check=False).returncode != 0:
                msg = f"installing {wheel} failed ({' '.join(cmd)})"
                raise BuildError(msg)
            print(f"installed {wheel.name}; `pip install pybullet=={VERSION}` goes back")
    except BuildError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
