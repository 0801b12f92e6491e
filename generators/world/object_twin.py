"""The objects' render twin: a second PyBullet client that only draws the objects.

A lean instance (``World.begin(..., scenery_visuals=False)``) is simulated in a client
whose renderer is switched off (:func:`physics_only_client`): its ``resetSimulation``,
table, Panda and object bodies then build no render meshes, which were most of the reset's
cost (a lego brick's body: 1.94 ms with its visual shape, 0.11 ms without, measured by
``benchmarks/bench_generate.py --breakdown``). Its composite renders draw the objects here
instead, over the world's cached background: this client is never reset or stepped, and
keeps a pool of bodies per shape, created once with the same shapes as the world's
(:func:`~.assets.create_shape_ids`). Each instance takes the first bodies of each shape's
pool in scene order, recoloured; the rest are made transparent, which TinyRenderer skips
(as the world hides its scenery for a composite render). Before each render the pool's
bodies take their objects' poses from the physics client.

The twin's pixels are the world's: the same meshes, colours and textures at the same
poses, drawn by the same renderer with the scenery absent instead of transparent. Body ids
differ, so segmentation is read through the twin's own lookup table. Proven by ``generate``
+ ``verify`` of every committed part (``docs/performance.md``) and by
``tests/world/test_object_twin.py``, which compares the twin's renders with the world's
own, pixel for pixel.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from types import ModuleType

import numpy as np
from numpy.typing import NDArray

from nsrmp_bench.generators.world.assets import OBJECT_DYNAMICS, ShapeIds, create_shape_ids
from nsrmp_bench.scene import SceneObject
from nsrmp_bench.vocabulary import COLOUR_RGBA

__all__ = ["ObjectTwin", "object_look", "physics_only_client"]

_WHITE = (1.0, 1.0, 1.0, 1.0)
_TWIN_PARK = (0.0, 0.0, -50.0)


def physics_only_client(pb: ModuleType) -> int:
    """A DIRECT client without its renderer (TinyRenderer unloaded): bodies, resets and
    URDF loads build no render meshes. It cannot render (``getCameraImage`` returns an
    empty picture, ``getVisualShapeData`` raises); physics is untouched."""
    client = int(pb.connect(pb.DIRECT))
    if client < 0:
        msg = "PyBullet could not start a DIRECT client"
        raise RuntimeError(msg)
    # the renderer is a plugin linked into PyBullet, loaded at connect: loading it by
    # name returns the loaded one's id
    plugin = int(pb.loadPlugin("tinyRendererPlugin", physicsClientId=client))
    if plugin < 0:
        pb.disconnect(physicsClientId=client)
        msg = "PyBullet has no tinyRendererPlugin to unload; this PyBullet build differs"
        raise RuntimeError(msg)
    pb.unloadPlugin(plugin, physicsClientId=client)
    return client


def object_look(obj: SceneObject) -> tuple[str | None, tuple[float, float, float, float]]:
    """(dice texture colour or None, rgba) of an object's body, as the world colours it."""
    if obj.shape == "dice":
        return obj.colour, _WHITE
    return None, COLOUR_RGBA[obj.colour]


class ObjectTwin:
    """A render-only client with a pool of object bodies per shape (see the module doc)."""

    def __init__(self, pb: ModuleType, texture_files: dict[str, Path]) -> None:
        self.pb = pb
        self.client = int(pb.connect(pb.DIRECT))
        if self.client < 0:
            msg = "PyBullet could not start a DIRECT client for the render twin"
            raise RuntimeError(msg)
        self._texture_files = texture_files
        self._textures: dict[str, int] = {}
        self._shapes: dict[str, ShapeIds] = {}
        self._pool: dict[str, list[int]] = {}
        # the look each pool body shows now: (texture colour or None, rgba); alpha 0 hidden
        self._look: dict[int, tuple[str | None, tuple[float, ...]]] = {}
        self._shown: list[int] = []
        self.bodies: tuple[int, ...] = ()
        self.lut = np.full(1, -1, dtype=np.int16)
        self._closed = False

    @property
    def pool_sizes(self) -> dict[str, int]:
        """Bodies kept per shape: the most of that shape any instance has had."""
        return {shape: len(pool) for shape, pool in self._pool.items()}

    def _new_body(self, shape: str) -> int:
        pb, c = self.pb, self.client
        if shape not in self._shapes:
            self._shapes[shape] = create_shape_ids(pb, c, shape)
        ids = self._shapes[shape]
        body = int(pb.createMultiBody(
            baseMass=OBJECT_DYNAMICS["mass"], baseCollisionShapeIndex=ids.collision,
            baseVisualShapeIndex=ids.visual, basePosition=_TWIN_PARK,
            useMaximalCoordinates=False, physicsClientId=c))
        self._look[body] = (None, _WHITE)
        return body

    def _show(self, body: int, texture: str | None, rgba: tuple[float, ...]) -> None:
        if self._look[body] == (texture, rgba):
            return
        pb, c = self.pb, self.client
        if texture is not None:
            if texture not in self._textures:
                self._textures[texture] = int(pb.loadTexture(
                    str(self._texture_files[texture]), physicsClientId=c))
            pb.changeVisualShape(body, -1, textureUniqueId=self._textures[texture],
                                 rgbaColor=list(rgba), physicsClientId=c)
        else:
            pb.changeVisualShape(body, -1, rgbaColor=list(rgba), physicsClientId=c)
        self._look[body] = (texture, rgba)

    def assign(self, objects: Sequence[SceneObject]) -> tuple[int, ...]:
        """Give each object (scene order) a body of its shape, coloured as the world colours
        it; hide the bodies of the last instance that are not used now."""
        taken: dict[str, int] = {}
        bodies: list[int] = []
        for obj in objects:
            pool = self._pool.setdefault(obj.shape, [])
            k = taken.get(obj.shape, 0)
            taken[obj.shape] = k + 1
            if k == len(pool):
                pool.append(self._new_body(obj.shape))
            body = pool[k]
            self._show(body, *object_look(obj))
            bodies.append(body)
        used = set(bodies)
        for body in self._shown:
            if body not in used:
                texture, rgba = self._look[body]
                self._show(body, texture, (*rgba[:3], 0.0))
        self._shown = bodies
        self.bodies = tuple(bodies)
        n = self.pb.getNumBodies(physicsClientId=self.client)
        self.lut = np.full(n + 2, -1, dtype=np.int16)  # entry 0: PyBullet's -1
        for i, body in enumerate(bodies):
            self.lut[body + 1] = i
        return self.bodies

    def follow(self, physics_client: int, physics_bodies: Sequence[int]) -> None:
        """Put each of the instance's bodies where its object is in ``physics_client``."""
        pb, c = self.pb, self.client
        for body, source in zip(self.bodies, physics_bodies, strict=True):
            pos, orn = pb.getBasePositionAndOrientation(source, physicsClientId=physics_client)
            pb.resetBasePositionAndOrientation(body, pos, orn, physicsClientId=c)

    def segmentation(self, seg_ids: NDArray[np.int32]) -> NDArray[np.int16]:
        """Object indices (-1: none) of the twin's body ids."""
        out: NDArray[np.int16] = np.take(self.lut, seg_ids + 1)
        return out

    def close(self) -> None:
        """Disconnect the client (idempotent)."""
        if not self._closed:
            self.pb.disconnect(physicsClientId=self.client)
            self._closed = True
