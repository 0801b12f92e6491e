"""The C heap of a generating process: keep what large renders free for the next ones.

Every render hands back new arrays (a 1024x768 image is three of 3 MiB: RGBA, depth,
segmentation) and the world frees them once the episode holds its copy. glibc serves
blocks that large with ``mmap`` and gives them back with ``munmap`` (or trims the top of
its heap once 6 MiB are free there), so the next render's arrays are fresh pages, each
zeroed by the kernel on its first touch: about 3,000 page faults per 1024x768 episode,
8-10% of its CPU time (``benchmarks/bench_generate.py --breakdown``). With the thresholds
raised, freed blocks stay in the heap and are reused.

Nothing a generator computes reads an address, so the bytes do not change (every
committed part regenerates to its manifest with it); only the process's resident memory
stays at its high-water mark instead of shrinking between episodes.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools

M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
"""``mallopt`` parameters (glibc's ``malloc.h``)."""

MMAP_THRESHOLD = 32 << 20
"""Blocks below this come from the heap (glibc's own ceiling for the threshold)."""

TRIM_THRESHOLD = 256 << 20
"""Free memory at the top of the heap is given back only beyond this."""


@functools.cache
def retain_freed_memory() -> bool:
    """Raise glibc's ``mmap`` and trim thresholds for this process (once; later calls
    return the first answer). Returns whether they were raised: ``False`` where the C
    library is not glibc (musl, macOS), which keeps its own policy."""
    name = ctypes.util.find_library("c")
    if name is None:
        return False
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(
        mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
