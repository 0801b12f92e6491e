"""The PyBullet world: procedural assets, the table and the Panda, renders and targets.

Modules (import them by name; this package imports nothing heavy on its own):

* :mod:`.assets`: the procedural objects (5 cm cube, 5 cm dice with a generated pip
  atlas, 2x2 lego brick as box + 4 cylinders with exactly ``EXTENTS["lego"]``) and the
  "lean" Panda URDF written at runtime from pybullet_data's own text;
* :mod:`.world`: :class:`~.world.World`, one DIRECT client per process, reset before
  every instance and rebuilt with the table, the Panda and the instance's objects;
  settling; TinyRenderer renders;
* :mod:`.object_twin`: the physics-only client of lean instances and the render twin
  that draws their objects (a pool of bodies per shape, never reset);
* :mod:`.heap`: :func:`~.heap.retain_freed_memory`, which keeps the memory large renders
  free in the C heap for the next ones (what ``generate``'s workers do);
* :mod:`.targets`: amodal and visible boxes, visible fractions, centre depths;
* :mod:`.realise`: :func:`~.realise.realise`, the execution of a symbolic episode with
  typed rejections (:class:`~.realise.PhysicsRejection`), each step carried out by a
  placer (:class:`~.realise.TeleportPlacer`: teleport-and-settle, the default);
* :mod:`.contact_sheet`: :func:`~.contact_sheet.contact_sheet`, one PNG-able picture of
  an episode (also ``nsrmp-bench show``).

The Panda's pick-and-place lives in its own room, :mod:`nsrmp_bench.generators.robot`, and
replaying predictions with it in :mod:`nsrmp_bench.generators.replay`.

Choices, with the measurements behind them (``benchmarks/bench_render.py --breakdown``;
CPU ms per render, 15 objects, 2 CPU cores):

=============================================  =========  ==========
scene variant                                  320x240    1024x768
=============================================  =========  ==========
table only                                     17-20      159
table + lean Panda + 15 objects (official)     19-21      188
table + stock Panda + 15 objects               40         204
floor + table + lean Panda + 15 objects        42         405
lean Panda + 15 objects, no table              7          52
=============================================  =========  ==========

* **No floor** (+21 ms per 320x240 image for pixels that only show around the table):
  pixels showing no body are filled with a flat colour instead.
* **Lean Panda** (its collision meshes as visuals: 3.5k instead of 103k triangles,
  -19 ms per image), two-tone, standing on the far edge at (0, 0.5), folded back in a rest
  pose that keeps every link at y >= 0.32, behind every object (a test checks that the
  robot is in view but covers no pixel of the workspace).
* **The table's pixels are the cost** (2/3 of a render: TinyRenderer spends ~0.2 us per
  covered pixel). The table and the resting robot never change, so teleport execution
  renders them once per camera (:meth:`~.world.World.prepare_background`) and then
  renders only the objects over that image (``World.render(composite=True)``): 4-6 ms
  instead of 19-21 ms at 320x240, 47 instead of 181 ms at 1024x768. The composite equals
  the full render except for the odd pixel where an object's bottom edge ties with the
  table top in depth (2 of 34,000 object pixels over 10 scenes); ``realise(...,
  composite=False)`` renders every image in full.
* **Pixel centres**: TinyRenderer samples pixel (i, j) half a pixel off the
  :class:`~nsrmp_bench.geometry.camera.Camera` convention (at ``(j, i + 1)``); the world
  renders with a projection shifted by half a pixel
  (``Camera.projection_matrix_gl_pixel_centred``), after which rendered masks and projected
  silhouettes coincide (IoU 0.9998).
* **Determinism**: every instance starts from a reset simulation (Bullet keeps history
  in its broadphase that taking bodies out and back in does not clear: the reason the
  v1 splits were withdrawn); objects are multibodies, scenery and robot never form contact
  pairs among themselves, pairs are processed in sorted order; tests realise episodes
  after other episodes, in shuffled orders and in a subprocess and compare every byte.
* **Settling** runs with 30 solver iterations (the world default, 50, is for grasping):
  28% less physics CPU, same rejections, drifts below 0.14 mm.
"""
