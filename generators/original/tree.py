"""The original authors' source tree: where it is, that it is the pinned commit, and what
its generator needs.

The tree is the root of ``dair-iitd/nsrmp`` at :data:`ORIGINAL_COMMIT` (the folder that holds
``data_generation/``), a clone or an export; nothing of it is copied into this package.
``pinned_files.json`` holds the git blob ids of the files the generator runs or loads at
that commit, so an export without ``.git`` is checked as strictly as a clone.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import sys
from importlib import resources
from pathlib import Path
from typing import Final

from nsrmp_bench.errors import InvalidArgument, MissingExtra

__all__ = [
    "GET_TREE",
    "NEEDED_MODULES",
    "ORIGINAL_COMMIT",
    "ORIGINAL_REPOSITORY",
    "check_modules",
    "check_pinned",
    "data_generation_dir",
    "git_blob_id",
    "pinned_files",
]

ORIGINAL_REPOSITORY: Final = "dair-iitd/nsrmp"
ORIGINAL_COMMIT: Final = "bf6ba543e04283a122a7275f7822a595b0a193b0"
GET_TREE: Final = (
    f"get it with `git clone https://github.com/{ORIGINAL_REPOSITORY} && git -C nsrmp checkout "
    f"{ORIGINAL_COMMIT[:7]}` and pass that folder (nsrmp)")
NEEDED_MODULES: Final[dict[str, str]] = {
    "pybullet": "pybullet", "numpy": "numpy", "cv2": "opencv-python-headless", "PIL": "pillow"}
"""What ``construct.py``'s imports need (module: the pip package that has it)."""

_LAYOUT: Final = ("construct.py", "configs.py", "manage.py",
                  "panda/construct/program_generator.py", "panda/construct/metadata.json")


def data_generation_dir(tree: str | Path, template: str = "SingleStep") -> Path:
    """The tree's ``data_generation`` folder, after checking it has the original's layout
    and the template file ``template``; raises :class:`InvalidArgument` saying what is
    wrong and how to get the tree."""
    tree = Path(tree)
    if not tree.is_dir():
        what = "is a file" if tree.exists() else "does not exist"
        msg = (
            f"--tree {tree} {what}; expected the root of the original NSRMP repository "
            f"({ORIGINAL_REPOSITORY} at {ORIGINAL_COMMIT[:7]}): {GET_TREE}")
        raise InvalidArgument(msg)
    dg = tree / "data_generation"
    missing = [n for n in _LAYOUT if not (dg / n).is_file()]
    if missing:
        msg = (
            f"--tree {tree} is not the original NSRMP repository's layout: "
            f"{', '.join('data_generation/' + m for m in missing)} missing; expected the "
            f"root of {ORIGINAL_REPOSITORY} at {ORIGINAL_COMMIT[:7]} (the folder that holds "
            f"data_generation/): {GET_TREE}")
        raise InvalidArgument(msg)
    templates = dg / "panda" / "construct" / "templates"
    if not (templates / f"{template}.json").is_file():
        have = sorted(p.stem for p in templates.glob("*.json"))
        msg = (
            f"--template {template}: no {templates / (template + '.json')}; expected one of "
            f"{', '.join(have) or '(none: the templates folder is empty or missing)'}")
        raise InvalidArgument(msg)
    return dg


def git_blob_id(path: Path) -> str:
    """Git's object id of the file's bytes (sha1 of ``blob <size>\\0`` + content)."""
    data = path.read_bytes()
    return hashlib.sha1(b"blob %d\0" % len(data) + data, usedforsecurity=False).hexdigest()


def pinned_files() -> dict[str, str]:
    """``data_generation/``-relative path -> git blob id at :data:`ORIGINAL_COMMIT`."""
    text = resources.files(__package__).joinpath("pinned_files.json").read_text("utf-8")
    files: dict[str, str] = json.loads(text)["files"]
    return files


def check_pinned(tree: str | Path) -> Path:
    """The tree's ``data_generation`` folder, after checking every file the generator runs
    or loads is byte-identical to :data:`ORIGINAL_COMMIT`'s; raises
    :class:`InvalidArgument` naming the files that differ or are missing."""
    dg = data_generation_dir(tree)
    changed, missing = [], []
    for rel, blob in pinned_files().items():
        path = dg / rel
        if not path.is_file():
            missing.append(rel)
        elif git_blob_id(path) != blob:
            changed.append(rel)
    if changed or missing:
        parts = []
        if changed:
            verb = "differs" if len(changed) == 1 else "differ"
            parts.append(f"{len(changed)} {verb} ({', '.join(changed[:5])}"
                         f"{', ...' if len(changed) > 5 else ''})")
        if missing:
            parts.append(f"{len(missing)} missing ({', '.join(missing[:5])}"
                         f"{', ...' if len(missing) > 5 else ''})")
        msg = (
            f"--tree {tree} is not {ORIGINAL_REPOSITORY} at {ORIGINAL_COMMIT[:7]}: of the "
            f"{len(pinned_files())} files under data_generation/ the generator runs or loads, "
            f"{' and '.join(parts)}; check out the pinned commit unmodified (`git -C {tree} "
            f"checkout {ORIGINAL_COMMIT[:7]} -- data_generation`), or {GET_TREE}")
        raise InvalidArgument(msg)
    return dg


def _importable(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except ImportError:  # a finder that refuses the module, as a core-only install's tests do
        return False


def check_modules() -> None:
    """Raises :class:`MissingExtra` naming the modules ``construct.py`` needs that this
    interpreter lacks, with the ``pip install`` that adds them."""
    missing = [m for m in NEEDED_MODULES if not _importable(m)]
    if missing:
        msg = (
            f"the original generator needs the module(s) {', '.join(missing)}, which "
            f"{sys.executable} cannot import: `{sys.executable} -m pip install "
            f"{' '.join(NEEDED_MODULES[m] for m in missing)}` (or install the sim extra: "
            "pip install 'nsrmp-bench[sim]')")
        raise MissingExtra(msg)
