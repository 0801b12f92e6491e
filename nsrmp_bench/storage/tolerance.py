"""Robot episodes are compared within stated tolerances, everything else by exact hash.

A teleport episode is the same bytes on every machine: its arithmetic avoids every kernel
that numpy or the BLAS library picks by CPU feature (see ``verify``). A robot episode is a
long closed loop whose inverse kinematics runs through BLAS/LAPACK (OpenBLAS picks its
kernels by CPU: Haswell, SkylakeX, ...), so its floats differ in the last bits from one CPU
to the next (measured: 1e-15 m in poses, 1e-14 rad in joints). Its hash is exact on one
machine but not across machines; so every robot episode's manifest row also carries a
**tolerant summary**, and ``verify`` accepts a robot episode whose hash differs when its
summary agrees within :data:`ROBOT_TOLERANCES`:

* the symbolic episode (scene, program, instruction, states): exactly (its content hash);
* every object's pose in every state: position within ``position_mm``, quaternion
  components within ``orientation`` (q and -q are the same rotation);
* every amodal box in every state within ``box_px`` (pixel coordinates);
* the trajectory: sample count within ``trajectory_samples``, and every recorded
  end-effector position within ``trajectory_mm`` of the other run's path (the polyline
  through its samples, within ``trajectory_samples`` samples of the same time).

The path is compared as a path, not sample by sample: once the fingers touch an object,
contact dynamics amplify the last-bit differences to micrometres, enough for a segment's
step count (``ceil(seconds / dt)``) to come out one physics step (1/240 s) longer on one
machine, after which samples at the same index lie 2-10 mm apart along the same path
(measured on robot-v1/test with OpenBLAS Haswell vs Nehalem: 14 of 216 episodes). The
summary stores values quantised (0.1 mm, 1e-4, 0.1 px), far finer than the tolerances, so
the comparison never flips on a last bit.
"""

from __future__ import annotations

from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.canonical import content_hash
from nsrmp_bench.episode import Episode

__all__ = [
    "ROBOT_TOLERANCES",
    "TOLERANT_EXECUTORS",
    "compare_summaries",
    "comparison_spec",
    "tolerant_summary",
]

ROBOT_TOLERANCES: Final[dict[str, float]] = {
    "position_mm": 3.0,
    "orientation": 0.02,
    "box_px": 3.0,
    "trajectory_mm": 3.0,
    "trajectory_samples": 3,
}
"""Largest accepted differences between two machines' robot episodes.

Measured on robot-v1/test (216 episodes) between OpenBLAS's Haswell and Nehalem kernels:
every episode's hash differs; the largest differences are 0.7 mm in a final object
position, 0.0038 in a quaternion component (0.4 deg), 0.3 px in an amodal box and 0.55 mm
between end-effector paths, with equal sample counts. The tolerances leave a margin of 3-10
over that and stay far inside the robot's own success criterion (1.5 cm, 10 deg)."""

TOLERANT_EXECUTORS: Final = ("robot",)
"""Executors whose episodes are compared within tolerances across machines."""

SUMMARY_VERSION: Final = 1
_MM: Final = 1e-4  # metres per unit of the stored positions (0.1 mm)
_QUAT: Final = 1e-4
_PX: Final = 0.1


def _ints(a: NDArray[Any], unit: float) -> list[int]:
    flat = np.asarray(a, dtype=np.float64).reshape(-1)
    return [int(v) for v in np.rint(np.nan_to_num(flat, nan=0.0) / unit).tolist()]


def tolerant_summary(episode: Episode) -> dict[str, Any] | None:
    """The summary a robot episode's manifest row carries; None for other episodes."""
    r = episode.rendering
    if r is None or r.executor not in TOLERANT_EXECUTORS or r.trajectory is None:
        return None
    poses = np.asarray(r.targets.poses, dtype=np.float64)
    traj = r.trajectory
    return {
        "v": SUMMARY_VERSION,
        "symbolic": content_hash(episode.symbolic.to_dict()),
        "shape": list(poses.shape[:2]),
        "positions": _ints(poses[..., :3], _MM),
        "orientations": _ints(poses[..., 3:7], _QUAT),
        "boxes": _ints(r.targets.boxes_amodal, _PX),
        "samples": len(traj.time),
        "ee": _ints(np.asarray(traj.ee_pose)[:, :3], _MM),
    }


def comparison_spec() -> dict[str, Any]:
    """What a manifest with robot episodes says about how they are compared."""
    return {
        "exact": "every episode without a tolerant summary (teleport): content hash",
        "tolerant": {
            "executors": list(TOLERANT_EXECUTORS),
            "why": ("robot episodes are not bit-stable across CPUs: the inverse kinematics "
                    "runs through BLAS/LAPACK kernels chosen by CPU; compared within "
                    "tolerances instead"),
            "tolerances": dict(ROBOT_TOLERANCES),
            "trajectory": ("every end-effector sample within trajectory_mm of the other "
                           "path (polyline), within trajectory_samples samples in time"),
        },
    }


def _max_diff(a: list[int], b: list[int], unit: float) -> float:
    if not a:
        return 0.0
    d = np.abs(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64))
    return float(d.max()) * unit


def _path_distance(a: NDArray[np.float64], b: NDArray[np.float64], window: int) -> float:
    """Largest distance from a sample of path ``a`` to path ``b`` (the polyline through
    its samples), looking only at ``b``'s segments within ``window`` samples of the same
    index."""
    n, m = len(a), len(b)
    if n == 0 or m == 0:
        return 0.0 if n == m else float("inf")
    idx = np.arange(n)
    best = np.full(n, np.inf)
    for off in range(-window, window + 1):
        j = np.clip(idx + off, 0, m - 1)
        s0, s1 = b[j], b[np.minimum(j + 1, m - 1)]
        v = s1 - s0
        d = a - s0
        vv = (v * v).sum(axis=1)
        t = np.clip(np.where(vv > 0, (d * v).sum(axis=1) / np.where(vv > 0, vv, 1.0), 0.0),
                    0.0, 1.0)
        r = d - t[:, None] * v
        best = np.minimum(best, np.sqrt((r * r).sum(axis=1)))
    return float(best.max())


def compare_summaries(
    local: dict[str, Any] | None, committed: dict[str, Any] | None
) -> list[str]:
    """What differs beyond :data:`ROBOT_TOLERANCES` (empty: the episodes agree)."""
    tol = ROBOT_TOLERANCES
    if local is None or committed is None:
        return ["no tolerant summary to compare (not a robot episode on one side)"]
    if local.get("v") != committed.get("v"):
        return [f"summary version {local.get('v')} here, {committed.get('v')} committed"]
    if local["symbolic"] != committed["symbolic"]:
        return ["the symbolic episode differs (scene, program or instruction)"]
    if local["shape"] != committed["shape"]:
        return [f"{local['shape']} states x objects here, {committed['shape']} committed"]
    out = []
    d = _max_diff(local["positions"], committed["positions"], _MM) * 1000.0
    if d > tol["position_mm"]:
        out.append(f"an object pose differs by {d:.2f} mm (> {tol['position_mm']} mm)")
    qa = np.asarray(local["orientations"], dtype=np.float64).reshape(-1, 4)
    qb = np.asarray(committed["orientations"], dtype=np.float64).reshape(-1, 4)
    if qa.size:
        dq = np.minimum(np.abs(qa - qb).max(axis=1), np.abs(qa + qb).max(axis=1))
        if float(dq.max()) * _QUAT > tol["orientation"]:
            out.append(f"an object orientation differs by {float(dq.max()) * _QUAT:.4f} "
                       f"(> {tol['orientation']} per quaternion component)")
    d = _max_diff(local["boxes"], committed["boxes"], _PX)
    if d > tol["box_px"]:
        out.append(f"an amodal box differs by {d:.1f} px (> {tol['box_px']} px)")
    ds = abs(int(local["samples"]) - int(committed["samples"]))
    if ds > tol["trajectory_samples"]:
        out.append(f"the trajectory has {local['samples']} samples here, "
                   f"{committed['samples']} committed")
    pa = np.asarray(local["ee"], dtype=np.float64).reshape(-1, 3) * _MM
    pb = np.asarray(committed["ee"], dtype=np.float64).reshape(-1, 3) * _MM
    window = int(tol["trajectory_samples"])
    d = 1000.0 * max(_path_distance(pa, pb, window), _path_distance(pb, pa, window))
    if d > tol["trajectory_mm"]:
        out.append(f"the end-effector path differs by {d:.2f} mm (> {tol['trajectory_mm']} mm)")
    return out
