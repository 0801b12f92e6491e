"""The shim that runs the original ``data_generation/construct.py`` unchanged, headless.

Run as a file in a fresh process (``python .../shim.py DATA_GENERATION_DIR SEED ARGS...``;
:func:`nsrmp_bench.generators.original.run.run_original` does it), so that nothing of this
package is imported into the original's process. It imports PyBullet and replaces three
functions on the ``pybullet`` module object (no file of the original tree is modified):

1. ``connect(GUI, ...)`` by ``connect(DIRECT)``;
2. ``resetDebugVisualizerCamera(**kw)`` by storing ``kw``;
3. ``getCameraImage(w, h)`` without matrices by the GUI mode's own camera:
   view = ``computeViewMatrixFromYawPitchRoll(stored target, distance, yaw, pitch, roll 0,
   up axis z)``, projection = ``computeProjectionMatrix(-a*0.01, a*0.01, -0.01, 0.01,
   0.01, 1000)`` with a = w/h, renderer ``ER_TINY_RENDERER``. This reproduces the shipped
   ``examples/00001`` bit-exactly (``reference/nsrm-original-datagen.md`` section 1.9).
   ``w`` and ``h`` are turned into ints (the original's parser reads them as strings).

It then seeds Python's ``random`` and ``np.random`` with SEED (the original seeds nothing;
the caller also fixes ``PYTHONHASHSEED``) and runs ``construct.py`` as ``__main__``
(``runpy``) with the working directory and ``sys.path[0]`` = DATA_GENERATION_DIR, ARGS as
its command line. On exit it prints :data:`RUNPY_MARK` and the seconds spent in
``construct.py`` to stderr.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Sequence
from types import ModuleType
from typing import Any, Final

SHIM_VERSION: Final = "nsrm-original-shim-v1"
"""The shim's behaviour id: a change to what it patches or seeds makes a new version."""

RUNPY_MARK: Final = "nsrm-original-shim: runpy_s="


def run(dg: str, seed: int, construct_args: Sequence[str]) -> None:
    """Patch PyBullet, seed, run ``dg/construct.py`` as ``__main__`` with ``construct_args``."""
    sys.path[0] = dg  # as `python construct.py` run from data_generation (not this folder)
    import importlib
    import random
    import runpy

    np: ModuleType = importlib.import_module("numpy")
    p: Any = importlib.import_module("pybullet")

    real_connect = p.connect
    real_camera_image = p.getCameraImage
    camera: dict[str, Any] = {}

    def connect(method: int, *args: object, **kwargs: object) -> int:
        if method == p.GUI:
            return int(real_connect(p.DIRECT))
        return int(real_connect(method, *args, **kwargs))

    def reset_debug_visualizer_camera(cameraDistance: float, cameraYaw: float,
                                      cameraPitch: float, cameraTargetPosition: Sequence[float],
                                      **_: object) -> None:
        camera.update(distance=cameraDistance, yaw=cameraYaw, pitch=cameraPitch,
                      target=list(cameraTargetPosition))

    def get_camera_image(width: int, height: int, viewMatrix: Sequence[float] | None = None,
                         projectionMatrix: Sequence[float] | None = None,
                         **kwargs: object) -> Any:
        w, h = int(width), int(height)
        if viewMatrix is None and projectionMatrix is None:
            if not camera:
                msg = "getCameraImage without matrices before resetDebugVisualizerCamera"
                raise RuntimeError(msg)
            viewMatrix = p.computeViewMatrixFromYawPitchRoll(
                camera["target"], camera["distance"], camera["yaw"], camera["pitch"], 0, 2)
            a = w / h
            projectionMatrix = p.computeProjectionMatrix(-a * 0.01, a * 0.01, -0.01, 0.01,
                                                         0.01, 1000)
            kwargs.setdefault("renderer", p.ER_TINY_RENDERER)
        return real_camera_image(w, h, viewMatrix, projectionMatrix, **kwargs)

    p.connect = connect
    p.resetDebugVisualizerCamera = reset_debug_visualizer_camera
    p.getCameraImage = get_camera_image

    os.chdir(dg)
    script = os.path.join(dg, "construct.py")
    sys.argv = [script, *construct_args]
    random.seed(seed)
    np.random.seed(seed)
    start = time.perf_counter()
    try:
        runpy.run_path(script, run_name="__main__")
    finally:
        print(f"{RUNPY_MARK}{time.perf_counter() - start:.3f}", file=sys.stderr, flush=True)


if __name__ == "__main__":
    run(sys.argv[1], int(sys.argv[2]), sys.argv[3:])
