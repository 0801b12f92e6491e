"""The reconstruction's reference row (``nsrmp-bench reconstruct --renderer sim``): PyBullet
re-renders the predicted object locations (no network).

For each predicted state, every object whose box changed from the previous state is put at
its predicted 3D centre with its initial orientation, and the scene is rendered with the
episode's own world settings and camera (``generators.world``; no physics runs). The 3D
centre is the file's ``positions`` entry where the object's box at that state is its final
box; otherwise (an intermediate state, or a file without ``positions``) its box centre
back-projected at the depth of its previous centre.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.episode import Episode
from nsrmp_bench.geometry.boxes import MOVE_TOLERANCE, moved_objects

__all__ = ["SimRenderer"]


class SimRenderer:
    """One PyBullet world, reused for every episode (close it when done)."""

    def __init__(self) -> None:
        self._worlds: dict[tuple[Any, str], Any] = {}

    def _world(self, episode: Episode) -> Any:
        import json

        from nsrmp_bench.generators.world.world import World, WorldConfig

        r = episode.rendering
        assert r is not None
        settings: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v
                                    for k, v in dict(r.physics.get("world", {})).items()}
        key = (r.camera, json.dumps(settings, sort_keys=True))
        world = self._worlds.get(key)
        if world is None:
            world = World(r.camera, config=WorldConfig(**settings))
            self._worlds[key] = world
        return world

    def chain(self, episode: Episode, step_boxes: NDArray[Any],
              positions: NDArray[Any] | None) -> list[NDArray[np.uint8]]:
        """The renders of the predicted states after each step (``step_boxes`` (S, N, 4))."""
        from nsrmp_bench.scene import Pose

        r = episode.rendering
        assert r is not None
        world = self._world(episode)
        cam = r.camera
        poses = np.asarray(r.targets.poses[0], np.float64).copy()
        boxes = np.asarray(r.targets.boxes_amodal[0], np.float64)
        steps = np.asarray(step_boxes, np.float64)
        final = steps[-1] if len(steps) else boxes
        world.begin(episode.symbolic.scene.objects)
        for i, p in enumerate(poses):
            world.place(i, Pose(tuple(p[:3]), tuple(p[3:])))
        images = []
        for nxt in steps:
            for i in moved_objects(boxes, nxt):
                at_final = np.abs(nxt[i] - final[i]).max() <= MOVE_TOLERANCE
                if positions is not None and at_final:
                    centre = np.asarray(positions[i], np.float64)
                else:
                    _, depth = cam.project(poses[i, :3][None])
                    uv = np.array([[(nxt[i, 0] + nxt[i, 2]) / 2, (nxt[i, 1] + nxt[i, 3]) / 2]])
                    centre = cam.backproject(uv, depth)[0]
                poses[i, :3] = centre
                world.place(int(i), Pose(tuple(centre), tuple(poses[i, 3:])))
            images.append(np.ascontiguousarray(world.render(cam).rgb))
            boxes = nxt
        return images

    def close(self) -> None:
        """Disconnect the worlds."""
        for world in self._worlds.values():
            world.close()
        self._worlds.clear()
