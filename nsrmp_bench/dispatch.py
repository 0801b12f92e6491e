"""Which CPU-dependent kernels this process runs: numpy's SIMD dispatch and the BLAS core.

numpy picks SIMD kernels by CPU feature at import (``NPY_DISABLE_CPU_FEATURES`` can turn
some off); OpenBLAS picks its kernels by CPU too (``OPENBLAS_CORETYPE``). Generation avoids
every such kernel where a result reaches stored bytes or a decision (``math.*`` instead of
numpy's transcendental ufuncs), except in the robot's inverse kinematics, whose episodes are
compared within tolerances (``storage/tolerance.py``). Manifests record both, so that
``verify`` can name the cause when two machines disagree.
"""

from __future__ import annotations

import ctypes
import glob
import importlib
import os
from functools import cache
from types import ModuleType

import numpy as np

__all__ = ["blas_core", "dispatch_versions", "lowest_dispatch_env", "numpy_simd"]

DISPATCH_KEYS = ("numpy_simd", "blas")
"""The ``versions`` keys of a manifest that describe CPU-dependent kernels."""


def _cpu_tables() -> tuple[list[str], list[str], dict[str, bool]]:
    try:
        table: ModuleType = importlib.import_module("numpy._core._multiarray_umath")
    except ImportError:  # numpy 1.x
        table = importlib.import_module("numpy.core._multiarray_umath")
    return (list(table.__cpu_baseline__), list(table.__cpu_dispatch__),
            dict(table.__cpu_features__))


def numpy_simd() -> str:
    """numpy's SIMD features in use, e.g. ``baseline X86_V2; dispatch X86_V3``."""
    try:
        baseline, dispatch, features = _cpu_tables()
    except (ImportError, AttributeError):
        return "unknown"
    used = [f for f in dispatch if features.get(f)]
    return f"baseline {' '.join(baseline) or 'none'}; dispatch {' '.join(used) or 'none'}"


@cache
def blas_core() -> str:
    """The BLAS library numpy uses and, for OpenBLAS, the CPU core its kernels are for."""
    here = os.path.dirname(np.__file__)
    for lib in sorted(glob.glob(os.path.join(here + ".libs", "*openblas*"))):
        try:
            handle = ctypes.CDLL(lib)
        except OSError:
            continue
        for name in ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename",
                     "openblas_get_corename64_", "openblas_get_corename"):
            fn = getattr(handle, name, None)
            if fn is not None:
                fn.restype = ctypes.c_char_p
                return f"OpenBLAS {fn().decode()}"
    return "unknown"


def dispatch_versions() -> dict[str, str]:
    """The entries a manifest's ``versions`` records about CPU-dependent kernels."""
    return {"numpy_simd": numpy_simd(), "blas": blas_core()}


def lowest_dispatch_env() -> dict[str, str]:
    """Environment variables that make a new process use numpy's baseline kernels only,
    a pre-AVX OpenBLAS core and OpenCV without its optional SIMD paths: the other end
    from the default dispatch (for tests)."""
    try:
        _, dispatch, _ = _cpu_tables()
    except (ImportError, AttributeError):
        dispatch = []
    env = {"OPENBLAS_CORETYPE": "Nehalem",
           "OPENCV_CPU_DISABLE": "AVX512_SKX,AVX2,FMA3,AVX,POPCNT,SSE4_2,SSE4_1"}
    if dispatch:
        env["NPY_DISABLE_CPU_FEATURES"] = " ".join(dispatch)
    return env
