"""The one guard for optional dependencies.

Scoring and reading need only numpy, h5py and pandas. Anything else is imported through
:func:`require`, which turns a missing package into a :class:`MissingExtra` naming the
extra to install.
"""

from __future__ import annotations

import importlib
import os
import sys
from types import ModuleType

from nsrmp_bench.errors import MissingExtra

__all__ = ["require"]

_EXTRA_OF: dict[str, str] = {
    "pybullet": "sim",
    "pybullet_data": "sim",
    "cv2": "sim",
    "mcap": "mcap",
    "mcap_protobuf": "mcap",
    "foxglove_schemas_protobuf": "mcap",
    "torch": "torch",
    "pooch": "download",
    "pyarrow": "parquet",
}


def _import_quietly(module: str) -> ModuleType:
    """Import ``module``; PyBullet's C banner ("pybullet build time ...") goes to /dev/null."""
    if module.split(".")[0] != "pybullet" or module in sys.modules:
        return importlib.import_module(module)
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            return importlib.import_module(module)
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def require(module: str) -> ModuleType:
    """Import ``module`` or raise :class:`MissingExtra` naming the extra that provides it."""
    try:
        return _import_quietly(module)
    except ImportError as exc:
        top = module.split(".")[0]
        extra = _EXTRA_OF.get(top, "all")
        msg = (
            f"this feature needs the optional package {top!r}, which is not installed; "
            f"install it with: pip install 'nsrmp-bench[{extra}]'"
        )
        raise MissingExtra(msg) from exc
