"""Hand-built scenes and episodes for the world tests (no sampler involved).

Poses are box centres; ``on_table`` and ``on_top`` give the exact resting centres that
the symbolic executor would compute for a free spot and for a ``top`` step.
"""

from __future__ import annotations

from collections.abc import Sequence

from nsrmp_bench.dsl.program import GroundedStep, Node, Program
from nsrmp_bench.episode import Instruction, SeedInfo, SymbolicEpisode
from nsrmp_bench.scene import Pose, Scene, SceneObject, State, yaw_quaternion
from nsrmp_bench.vocabulary import EXTENTS, TABLE_TOP_Z


def on_table(shape: str, x: float, y: float, yaw: float = 0.0) -> Pose:
    """The resting pose of ``shape`` on the table top at (x, y)."""
    return Pose((x, y, TABLE_TOP_Z + EXTENTS[shape][2] / 2.0), yaw_quaternion(yaw))


def on_top(lower: Pose, lower_shape: str, shape: str, yaw: float | None = None) -> Pose:
    """The resting pose of ``shape`` centred on top of ``lower``."""
    x, y, z = lower.position
    orn = lower.orientation if yaw is None else yaw_quaternion(yaw)
    return Pose((x, y, z + (EXTENTS[lower_shape][2] + EXTENTS[shape][2]) / 2.0), orn)


def scene_of(items: Sequence[tuple[str, str, Pose]]) -> Scene:
    """A scene from (shape, colour, pose) triples."""
    return Scene(tuple(SceneObject(s, c) for s, c, _ in items), tuple(p for _, _, p in items))


def moved(state: State, index: int, pose: Pose) -> State:
    """``state`` with object ``index`` at ``pose``."""
    return tuple(pose if i == index else p for i, p in enumerate(state))


def chain(scene: Scene, moves: Sequence[tuple[str, int, int, Pose]]) -> tuple[
        tuple[State, ...], tuple[GroundedStep, ...]]:
    """States and grounded steps of ``(action, subject, reference, target pose)`` moves."""
    states = [scene.initial]
    steps = []
    for action, subject, reference, pose in moves:
        states.append(moved(states[-1], subject, pose))
        steps.append(GroundedStep(action, subject, reference))
    return tuple(states), tuple(steps)


def grid_scene(shapes: Sequence[str], colours: Sequence[str], *, spacing: float = 0.12,
               yaws: Sequence[float] | None = None) -> Scene:
    """Objects on a 5-wide grid over the workspace, well apart (nothing occludes)."""
    items = []
    for i, (shape, colour) in enumerate(zip(shapes, colours, strict=True)):
        r, c = divmod(i, 5)
        x = (c - 2) * spacing
        y = -0.15 + r * spacing
        yaw = 0.0 if yaws is None else yaws[i]
        items.append((shape, colour, on_table(shape, x, y, yaw)))
    return scene_of(items)


def _reference_nodes(nodes: list[Node], obj: SceneObject) -> int:
    nodes.append(Node("scene"))
    nodes.append(Node("filter", (len(nodes) - 1,), (obj.colour,)))
    nodes.append(Node("filter", (len(nodes) - 1,), (obj.shape,)))
    nodes.append(Node("unique", (len(nodes) - 1,)))
    return len(nodes) - 1


def symbolic_episode(scene: Scene, states: Sequence[State], steps: Sequence[GroundedStep],
                     episode_id: str = "world-test-0") -> SymbolicEpisode:
    """A SymbolicEpisode whose program names each step's objects by colour and shape."""
    nodes: list[Node] = [Node("idle")]
    chain_node = 0
    words = []
    for g in steps:
        s = _reference_nodes(nodes, scene.objects[g.subject])
        r = _reference_nodes(nodes, scene.objects[g.reference])
        nodes.append(Node("move", (chain_node, s, r), (g.action,)))
        chain_node = len(nodes) - 1
        words.append(f"put the {scene.objects[g.subject].label} {g.action} of the "
                     f"{scene.objects[g.reference].label}")
    text = (", then ".join(words) or "do nothing").capitalize() + "."
    return SymbolicEpisode(
        id=episode_id,
        generator="world-tests",
        seed=SeedInfo(0, 0),
        scene=scene,
        program=Program(tuple(nodes)),
        grounded=tuple(steps),
        instruction=Instruction(text=text, template_id="hand", phrasing="simple"),
        states=tuple(states),
    )


def determinism_cases() -> dict[str, tuple[Scene, tuple[State, ...], tuple[GroundedStep, ...]]]:
    """A few fixed episodes with stacks, side moves, all shapes and 3..12 objects."""
    cases = {}
    a = on_table("lego", 0.05, 0.02, 0.3)
    scene = scene_of([("lego", "red", a), ("cube", "blue", on_table("cube", 0.2, -0.1, 0.7)),
                      ("dice", "white", on_table("dice", -0.2, 0.1, 1.1))])
    b = on_top(a, "lego", "cube", 0.7)
    cases["stack"] = (scene, *chain(scene, [("top", 1, 0, b), ("top", 2, 1, on_top(b, "cube",
                                                                                  "dice", 1.1))]))
    shapes = ["cube", "dice", "lego"] * 4
    colours = ["red", "green", "blue", "cyan", "yellow", "magenta", "white"] * 2
    grid = grid_scene(shapes, colours[:12], yaws=[0.1 * i for i in range(12)])
    p0 = grid.initial[0]
    cases["crowded"] = (grid, *chain(grid, [
        ("right", 3, 0, on_table("cube", p0.position[0] + 0.06, p0.position[1] + 0.06, 0.3)),
        ("top", 7, 1, on_top(grid.initial[1], "dice", "dice", 0.2)),
        ("left", 2, 4, on_table("lego", -0.05, 0.2, 0.9)),
    ]))
    return cases
