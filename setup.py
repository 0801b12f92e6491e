"""Package discovery for the build (the rest of the metadata is in ``pyproject.toml``).

The wheel has one import namespace, ``nsrmp_bench``: ``generators/`` and
``reference_model/`` are mapped into it (``[tool.setuptools.package-dir]``), and every
package under the three folders is found here, so a new model's folder
(``reference_model/<name>/`` with an ``__init__.py``) ships without editing any list.
"""

from __future__ import annotations

from setuptools import find_packages, setup

MAPPED = {
    "nsrmp_bench": "nsrmp_bench",
    "nsrmp_bench.generators": "generators",
    "nsrmp_bench.reference_model": "reference_model",
}
"""Each package of the namespace and the folder that holds it (its sub-packages follow)."""

DATA_PACKAGES = ("nsrmp_bench.splits", "nsrmp_bench.leaderboards")
"""Folders shipped as package data only (``splits/``, ``leaderboards/``)."""


def packages() -> list[str]:
    """Every package of the namespace: the mapped folders and all their sub-packages."""
    found = [*DATA_PACKAGES]
    for name, folder in MAPPED.items():
        found += [name, *(f"{name}.{sub}" for sub in find_packages(folder))]
    return sorted(found)


if __name__ == "__main__":  # the build backend runs this file as a script
    setup(packages=packages())
