"""The one guard for optional dependencies.

Scoring and reading need only numpy, h5py and pandas. Anything else is imported through
:func:`require`, which turns a missing package into a :class:`MissingExtra` naming the
extra to install.
"""

from __future__ import annotations

import importlib
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
    "matplotlib": "plot",
}


def require(module: str) -> ModuleType:
    """Import ``module`` or raise :class:`MissingExtra` naming the extra that provides it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.split(".")[0]
        extra = _EXTRA_OF.get(top, "all")
        msg = (
            f"this feature needs the optional package {top!r}, which is not installed; "
            f"install it with: pip install 'nsrmp-bench[{extra}]'"
        )
        raise MissingExtra(msg) from exc
