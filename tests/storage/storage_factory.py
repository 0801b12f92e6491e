"""Deterministic episodes for the storage tests: real SymbolicEpisodes, synthetic renderings.

``make_episode(index, entropy=...)`` is a pure function of its arguments, so a child
process given the same seed makes the same bytes.
"""

from __future__ import annotations

import numpy as np

from nsrmp_bench.dsl.program import GroundedStep, Node, Program
from nsrmp_bench.episode import (
    Episode,
    Instruction,
    ObjectTargets,
    Observations,
    ReferenceLabel,
    Rendering,
    SeedInfo,
    SymbolicEpisode,
    Trajectory,
)
from nsrmp_bench.geometry.default_camera import official_camera
from nsrmp_bench.scene import Pose, Scene, SceneObject, yaw_quaternion
from nsrmp_bench.vocabulary import ACTIONS, COLOURS, PHRASINGS, RELATIONS, SHAPES

JOINTS = (*(f"panda_joint{k}" for k in range(1, 8)), "finger_l", "finger_r")


def _program(objects: list[SceneObject], grounded: list[GroundedStep], relational: bool
             ) -> Program:
    nodes: list[Node] = [Node("idle")]
    chain = 0
    for k, step in enumerate(grounded):
        subj = objects[step.subject]
        nodes += [Node("scene"), Node("filter", (len(nodes),), (subj.colour,))]
        nodes += [Node("filter", (len(nodes) - 1,), (subj.shape,))]
        nodes += [Node("unique", (len(nodes) - 1,))]
        subj_node = len(nodes) - 1
        ref = objects[step.reference]
        nodes += [Node("scene"), Node("filter", (len(nodes),), (ref.colour,))]
        nodes += [Node("unique", (len(nodes) - 1,))]
        if relational and k == 0:
            nodes += [Node("relate", (len(nodes) - 1,), (RELATIONS[0],))]
            nodes += [Node("unique", (len(nodes) - 1,))]
        ref_node = len(nodes) - 1
        nodes += [Node("move", (chain, subj_node, ref_node), (step.action,))]
        chain = len(nodes) - 1
    return Program(tuple(nodes))


def make_symbolic(index: int, *, entropy: int = 7, steps: int | None = None,
                  objects: int | None = None, split: str = "test-v1") -> SymbolicEpisode:
    """A deterministic symbolic episode for instance ``index``."""
    seed = SeedInfo(entropy, index)
    rng = seed.generator()
    n = objects if objects is not None else int(rng.integers(3, 7))
    s = steps if steps is not None else int(rng.integers(1, 3))
    combos = [(sh, c) for sh in SHAPES for c in COLOURS]
    picks = rng.permutation(len(combos))[:n]
    objs = [SceneObject(*combos[int(p)]) for p in picks]
    initial = tuple(
        Pose((float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-0.2, 0.2)), 0.65),
             yaw_quaternion(float(rng.uniform(0, 6.28))))
        for _ in range(n)
    )
    grounded = []
    states = [initial]
    for _ in range(s):
        a, b = (int(v) for v in rng.permutation(n)[:2])
        step = GroundedStep(ACTIONS[int(rng.integers(3))], a, b)
        grounded.append(step)
        cur = list(states[-1])
        ref = cur[b].position
        cur[a] = Pose((ref[0], ref[1], ref[2] + 0.05), cur[a].orientation)
        states.append(tuple(cur))
    relational = bool(rng.integers(2))
    program = _program(objs, grounded, relational)
    refs = tuple(
        ReferenceLabel(k, role, relational and k == 0 and role == "reference", False)
        for k in range(s) for role in ("subject", "reference")
    )
    instruction = Instruction(
        text=f"put the {objs[grounded[0].subject].label} somewhere #{index}",
        template_id=f"tpl-{s}-{int(relational)}",
        phrasing=PHRASINGS[index % 3],
        lexed="put the <C1> <T1> somewhere",
    )
    return SymbolicEpisode(
        id=f"{split}-{index:06d}",
        generator="test-gen-v1",
        seed=seed,
        scene=Scene(tuple(objs), initial),
        program=program,
        grounded=tuple(grounded),
        instruction=instruction,
        states=tuple(states),
        references=refs,
    )


def make_episode(index: int, *, entropy: int = 7, steps: int | None = None,
                 objects: int | None = None, images: bool = True, rendering: bool = True,
                 trajectory: bool = False, width: int = 32, height: int = 24,
                 split: str = "test-v1") -> Episode:
    """A deterministic episode; synthetic arrays of the contract shapes and dtypes."""
    sym = make_symbolic(index, entropy=entropy, steps=steps, objects=objects, split=split)
    if not rendering:
        return Episode(sym, None)
    rng = np.random.default_rng([entropy, index, 99])
    k, n = sym.num_steps + 1, sym.num_objects
    cam = official_camera(width, height)
    obs = None
    if images:
        rgb = np.zeros((k, height, width, 3), np.uint8)
        rgb[:] = rng.integers(0, 256, size=(1, 1, 1, 3), dtype=np.uint8)
        rgb[:, height // 3 :, :, :] = rng.integers(0, 256, size=(k, 1, width, 3), dtype=np.uint8)
        seg = np.full((k, height, width), -1, np.int16)
        for j in range(n):
            y, x = int(rng.integers(0, height - 4)), int(rng.integers(0, width - 4))
            seg[:, y : y + 3, x : x + 3] = j
            rgb[:, y : y + 3, x : x + 3] = rng.integers(0, 256, 3, dtype=np.uint8)
        depth = np.linspace(0.8, 1.6, height, dtype=np.float32)[None, :, None].repeat(
            k, 0).repeat(width, 2)
        obs = Observations(rgb=rgb, depth=np.ascontiguousarray(depth), segmentation=seg)
    poses = np.array([[list(p.position) + list(p.orientation) for p in st] for st in sym.states])
    lo = rng.uniform(0, width / 2, size=(k, n, 2))
    boxes = np.concatenate([lo, lo + rng.uniform(2, 8, size=(k, n, 2))], -1).astype(np.float32)
    visible = boxes.copy()
    visible[0, 0] = np.nan  # unseen in the initial state
    traj = None
    if trajectory:
        t = 12
        traj = Trajectory(
            time=np.arange(t) / 10.0,
            joint_positions=rng.normal(size=(t, len(JOINTS))),
            ee_pose=np.concatenate([rng.normal(size=(t, 3)), np.tile([0, 0, 0, 1.0], (t, 1))], 1),
            gripper=rng.uniform(0, 0.08, t),
            step=np.repeat(np.arange(sym.num_steps), -(-t // sym.num_steps))[:t].astype(np.int16),
            joint_names=JOINTS,
        )
    targets = ObjectTargets(
        poses=poses,
        boxes_amodal=boxes,
        boxes_visible=visible,
        visible_fraction=rng.uniform(0.2, 1, size=(k, n)).astype(np.float32),
        depth_centre=rng.uniform(0.8, 1.6, size=(k, n)).astype(np.float32),
    )
    render = Rendering(camera=cam, observations=obs, targets=targets,
                       executor="panda" if trajectory else "teleport", trajectory=traj,
                       physics={"settle_steps": 240, "timestep": 1 / 240})
    return Episode(sym, render)


def make_mixed(index: int, entropy: int = 7) -> Episode:
    """A factory mixing variants: every 5th without rendering, every 3rd with a trajectory."""
    if index % 5 == 4:
        return make_episode(index, entropy=entropy, rendering=False)
    return make_episode(index, entropy=entropy, trajectory=index % 3 == 0)
