"""The arrays of an episode in their stored form: checked shapes, contract dtypes.

:func:`episode_arrays` is the one place that turns an :class:`~nsrmp_bench.episode.Episode`
into named arrays; the writer stores exactly these and the hash covers exactly these, so
an episode read back hashes like the one written.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nsrmp_bench.episode import Episode
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.storage.layout import ARRAY_SPECS, ArraySpec

__all__ = ["episode_arrays", "to_stored_dtype"]

_SPECS: dict[str, ArraySpec] = {s.name: s for s in ARRAY_SPECS}


def to_stored_dtype(name: str, value: ArrayLike, where: str) -> NDArray[Any]:
    """``value`` as a C-contiguous little-endian array of the stored dtype of ``name``.

    Floats are narrowed to the stored float width; integers must fit the stored integer
    type, else :class:`InvalidArgument` says which values do not.
    """
    spec = _SPECS[name]
    arr = np.asarray(value)
    if arr.ndim != spec.ndim:
        msg = (
            f"{where}: {name} must have {spec.ndim} dimensions, got shape {arr.shape}; "
            "see nsrmp_bench.episode for the expected layout"
        )
        raise InvalidArgument(msg)
    target = spec.dtype
    if arr.dtype != target:
        if target.kind in "iu":
            if arr.dtype.kind not in "iub":
                msg = f"{where}: {name} must hold integers ({target.name}), got {arr.dtype}"
                raise InvalidArgument(msg)
            info = np.iinfo(target)
            if arr.size and (int(arr.min()) < info.min or int(arr.max()) > info.max):
                msg = (
                    f"{where}: {name} has values in [{int(arr.min())}, {int(arr.max())}], "
                    f"outside {target.name} [{info.min}, {info.max}]"
                )
                raise InvalidArgument(msg)
        elif arr.dtype.kind not in "fiub":
            msg = f"{where}: {name} must hold numbers ({target.name}), got {arr.dtype}"
            raise InvalidArgument(msg)
        arr = arr.astype(target)
    return np.ascontiguousarray(arr)


def _expect(name: str, arr: NDArray[Any], shape: tuple[int | None, ...], where: str) -> None:
    ok = len(arr.shape) == len(shape) and all(
        want is None or got == want for got, want in zip(arr.shape, shape, strict=True)
    )
    if not ok:
        pretty = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        msg = (
            f"{where}: {name} has shape {arr.shape}, expected {pretty} "
            "(S+1 states, N objects, H x W camera pixels); fix the episode's arrays"
        )
        raise InvalidArgument(msg)


def episode_arrays(episode: Episode) -> dict[str, NDArray[Any]]:
    """The episode's arrays by logical name (``observations/rgb`` ...), checked and typed.

    Only present parts appear: no rendering gives an empty dict; a rendering read without
    images has no ``observations/*``; no trajectory, no ``trajectory/*``.
    """
    where = f"episode {episode.id}"
    rendering = episode.rendering
    out: dict[str, NDArray[Any]] = {}
    if rendering is None:
        return out
    states = episode.symbolic.num_steps + 1
    n = episode.symbolic.num_objects
    obs = rendering.observations
    if obs is not None:
        h, w = rendering.camera.height, rendering.camera.width
        image_checks: tuple[tuple[str, Any, tuple[int | None, ...]], ...] = (
            ("observations/rgb", obs.rgb, (states, h, w, 3)),
            ("observations/depth", obs.depth, (states, h, w)),
            ("observations/segmentation", obs.segmentation, (states, h, w)),
        )
        for name, value, shape in image_checks:
            arr = to_stored_dtype(name, value, where)
            _expect(name, arr, shape, where)
            out[name] = arr
    t = rendering.targets
    target_checks: tuple[tuple[str, Any, tuple[int | None, ...]], ...] = (
        ("targets/poses", t.poses, (states, n, 7)),
        ("targets/boxes_amodal", t.boxes_amodal, (states, n, 4)),
        ("targets/boxes_visible", t.boxes_visible, (states, n, 4)),
        ("targets/visible_fraction", t.visible_fraction, (states, n)),
        ("targets/depth_centre", t.depth_centre, (states, n)),
    )
    for name, value, shape in target_checks:
        arr = to_stored_dtype(name, value, where)
        _expect(name, arr, shape, where)
        out[name] = arr
    traj = rendering.trajectory
    if traj is not None:
        time = to_stored_dtype("trajectory/time", traj.time, where)
        length = time.shape[0]
        joints = to_stored_dtype("trajectory/joint_positions", traj.joint_positions, where)
        _expect("trajectory/joint_positions", joints, (length, None), where)
        if traj.joint_names and len(traj.joint_names) != joints.shape[1]:
            msg = (
                f"{where}: trajectory has {joints.shape[1]} joints but "
                f"{len(traj.joint_names)} joint_names; give one name per joint"
            )
            raise InvalidArgument(msg)
        out["trajectory/time"] = time
        out["trajectory/joint_positions"] = joints
        traj_checks: tuple[tuple[str, Any, tuple[int | None, ...]], ...] = (
            ("trajectory/ee_pose", traj.ee_pose, (length, 7)),
            ("trajectory/gripper", traj.gripper, (length,)),
            ("trajectory/step", traj.step, (length,)),
        )
        for name, value, shape in traj_checks:
            arr = to_stored_dtype(name, value, where)
            _expect(name, arr, shape, where)
            out[name] = arr
    return out
