"""The gold side of scoring: every target of a split in one table of flat numpy arrays.

:class:`GoldTable` is built once from episodes (or directly from arrays, for synthetic
data) and every metric is then a vectorised operation over it. Per-object arrays are flat
over all instances with ``obj_offsets``; per-step arrays are flat over all gold steps with
``step_offsets``; per-step boxes are flat over (instance, state after step k, object) with
``stepbox_offsets``. See :mod:`nsrmp_bench.scoring.ragged`.

Gold abstention (``abstain``: ``"no action"``, ``"not feasible"``, or none) is read per
instance from the episode's optional ``abstain`` attribute (None or ``""``: none; data
made before it existed has none), coded as a prediction's (``ABSTAIN_CODES``). An
episode's optional ``phenomenon`` becomes a breakdown category where some episode has one.

Gold boxes are the amodal boxes of the episode's rendering (``targets.boxes_amodal``), or,
for a symbolic-only episode, the projection of its symbolic states through the official
camera. Gold 3D positions are object centres in the final state.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, DTypeLike, NDArray

from nsrmp_bench.episode import Episode, SymbolicEpisode
from nsrmp_bench.episode_views import episode_boxes, episode_camera, episode_positions
from nsrmp_bench.errors import DataIntegrityError, InvalidArgument
from nsrmp_bench.scoring.ragged import offsets_from_lengths, positions_in_rows, row_ids
from nsrmp_bench.scoring.submission import ABSTAIN_CODES
from nsrmp_bench.vocabulary import ACTIONS

__all__ = ["CATEGORY_COLUMNS", "GoldTable", "load_episodes", "load_gold"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
B = NDArray[np.bool_]

CATEGORY_COLUMNS: tuple[str, ...] = (
    "steps",
    "objects",
    "relational",
    "relation_needed",
    "phrasing",
    "template",
)
"""The categories every breakdown uses (``SymbolicEpisode.categories()``)."""


def _as(a: ArrayLike, dtype: DTypeLike, shape_tail: tuple[int, ...], what: str) -> Any:
    arr = np.asarray(a, dtype=dtype)
    if arr.ndim != 1 + len(shape_tail) or arr.shape[1:] != shape_tail:
        msg = f"gold {what} must have shape (n, {', '.join(map(str, shape_tail))}), got {arr.shape}"
        if not shape_tail:
            msg = f"gold {what} must be one-dimensional, got shape {arr.shape}"
        raise InvalidArgument(msg)
    return arr


@dataclass(frozen=True, eq=False)
class GoldTable:
    """All scoring targets of a set of instances, as flat arrays (build with :meth:`build`)."""

    ids: tuple[str, ...]
    split: str | None
    n_objects: I64  # (I,)
    n_steps: I64  # (I,)
    obj_offsets: I64  # (I+1,)
    obj_instance: I64  # (O,)
    initial_boxes: F64  # (O, 4)
    final_boxes: F64  # (O, 4)
    final_positions: F64  # (O, 3)
    moved: B  # (O,) moved by some step
    n_moved: I64  # (I,)
    step_offsets: I64  # (I+1,)
    step_instance: I64  # (T,)
    actions: NDArray[np.int8]  # (T,) index into ACTIONS
    subjects: I64  # (T,) object index within the instance
    references: I64  # (T,)
    stepbox_offsets: I64  # (I+1,) over S_i * N_i entries
    step_boxes: F64  # (P, 4) boxes after step k, (instance, k, object) order
    stepbox_step: I64  # (P,) global step index t of the state each entry belongs to
    stepbox_moved: B  # (P,) the object was moved by one of steps 1..k
    image_size: I64  # (I, 2) width, height
    categories: pd.DataFrame  # index: ids; columns CATEGORY_COLUMNS (and any others)
    source: str = ""
    index: dict[str, int] = field(default_factory=dict)
    abstain: NDArray[np.int8] | None = None  # (I,) gold abstain code; None: none anywhere

    @property
    def abstain_codes(self) -> NDArray[np.int8]:
        """(I,) the gold abstain code of each instance (0: the instruction is carried out)."""
        if self.abstain is None:
            return np.zeros(len(self.ids), dtype=np.int8)
        return self.abstain

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def n_instances(self) -> int:
        """Number of instances."""
        return len(self.ids)

    @property
    def single_step(self) -> B:
        """Instances with exactly one step (the CLIPort comparison's subset)."""
        out: B = self.n_steps == 1
        return out

    @property
    def max_steps(self) -> int:
        """The most steps of any instance (0 for an empty table)."""
        return int(self.n_steps.max()) if len(self.n_steps) else 0

    # -- construction -------------------------------------------------------------------
    @classmethod
    def build(
        cls,
        *,
        ids: Sequence[str],
        n_objects: NDArray[Any],
        n_steps: NDArray[Any],
        initial_boxes: NDArray[Any],
        final_boxes: NDArray[Any],
        final_positions: NDArray[Any],
        actions: NDArray[Any] | Sequence[str],
        subjects: NDArray[Any],
        references: NDArray[Any],
        step_boxes: NDArray[Any],
        image_size: NDArray[Any],
        categories: pd.DataFrame | None = None,
        split: str | None = None,
        source: str = "",
        abstain: Sequence[str | None] | NDArray[Any] | None = None,
    ) -> GoldTable:
        """Check the arrays' shapes and derive offsets, moved masks and per-step masks.

        ``actions`` are action names or indices into ``ACTIONS``; ``subjects`` and
        ``references`` are object indices within their instance; ``step_boxes`` holds the
        boxes after each step, (instance, step, object) order. ``abstain`` is each
        instance's gold abstention: a value of ``ABSTAIN_VALUES`` or None / ``""`` (or
        its code, an integer array); None: no instance abstains.
        """
        ids_t = tuple(str(i) for i in ids)
        n_inst = len(ids_t)
        index = {k: i for i, k in enumerate(ids_t)}
        if len(index) != n_inst:
            counts = pd.Series(ids_t).value_counts()
            dup = str(counts.index[0])
            msg = f"gold instance id {dup!r} occurs more than once; ids must be unique in a split"
            raise DataIntegrityError(msg)
        n_obj = _as(n_objects, np.int64, (), "n_objects")
        n_st = _as(n_steps, np.int64, (), "n_steps")
        if len(n_obj) != n_inst or len(n_st) != n_inst:
            msg = (
                f"gold n_objects ({len(n_obj)}) and n_steps ({len(n_st)}) need one entry per "
                f"instance ({n_inst})"
            )
            raise InvalidArgument(msg)
        if n_inst and (n_obj.min() < 1 or n_st.min() < 0):
            msg = "every gold instance needs at least one object and a non-negative step count"
            raise InvalidArgument(msg)
        obj_off = offsets_from_lengths(n_obj)
        n_o = int(obj_off[-1])
        init = _as(initial_boxes, np.float64, (4,), "initial_boxes")
        fin = _as(final_boxes, np.float64, (4,), "final_boxes")
        pos = _as(final_positions, np.float64, (3,), "final_positions")
        for name, arr in (("initial_boxes", init), ("final_boxes", fin), ("final_positions", pos)):
            if len(arr) != n_o:
                msg = f"gold {name} has {len(arr)} rows; the instances have {n_o} objects in all"
                raise InvalidArgument(msg)
        step_off = offsets_from_lengths(n_st)
        n_t = int(step_off[-1])
        if isinstance(actions, np.ndarray) and actions.dtype.kind in "iu":
            act = actions.astype(np.int8)
        else:
            lookup = {a: i for i, a in enumerate(ACTIONS)}
            try:
                act = np.array([lookup[str(a)] for a in actions], dtype=np.int8)
            except KeyError as exc:
                msg = f"gold action {exc.args[0]!r} is not one of {list(ACTIONS)}"
                raise InvalidArgument(msg) from exc
        subj = _as(subjects, np.int64, (), "subjects")
        ref = _as(references, np.int64, (), "references")
        if not len(act) == len(subj) == len(ref) == n_t:
            msg = (
                f"gold actions/subjects/references have {len(act)}/{len(subj)}/{len(ref)} "
                f"entries; the instances have {n_t} steps in all"
            )
            raise InvalidArgument(msg)
        if n_t and (act.min() < 0 or act.max() >= len(ACTIONS)):
            msg = f"gold action codes must lie in 0..{len(ACTIONS) - 1}"
            raise InvalidArgument(msg)
        step_inst = row_ids(step_off)
        n_obj_of_step = n_obj[step_inst]
        for name, arr in (("subjects", subj), ("references", ref)):
            if n_t and ((arr < 0) | (arr >= n_obj_of_step)).any():
                msg = f"gold {name} must be object indices within their instance"
                raise InvalidArgument(msg)
        sb_off = offsets_from_lengths(n_st * n_obj)
        sboxes = _as(step_boxes, np.float64, (4,), "step_boxes")
        if len(sboxes) != int(sb_off[-1]):
            msg = (
                f"gold step_boxes has {len(sboxes)} rows; need steps x objects = "
                f"{int(sb_off[-1])} (the boxes after every step)"
            )
            raise InvalidArgument(msg)
        size = _as(image_size, np.int64, (2,), "image_size")
        if len(size) != n_inst:
            msg = f"gold image_size needs one (width, height) per instance, got {len(size)}"
            raise InvalidArgument(msg)

        # Derived: moved objects, and the step after which each object first moved.
        subj_global = obj_off[step_inst] + subj
        moved = np.zeros(n_o, dtype=bool)
        moved[subj_global] = True
        obj_inst = row_ids(obj_off)
        n_moved = np.bincount(obj_inst, weights=moved, minlength=n_inst).astype(np.int64)
        step_number = positions_in_rows(step_off) + 1  # 1-based within the instance
        first_move = np.full(n_o, np.iinfo(np.int64).max, dtype=np.int64)
        np.minimum.at(first_move, subj_global, step_number)
        sb_inst = row_ids(sb_off)
        q = positions_in_rows(sb_off)
        n_per = n_obj[sb_inst]
        k = q // np.maximum(n_per, 1) + 1
        j = q % np.maximum(n_per, 1)
        sb_step = step_off[sb_inst] + k - 1
        sb_moved = first_move[obj_off[sb_inst] + j] <= k

        if categories is None:
            cats = pd.DataFrame({"steps": n_st, "objects": n_obj}, index=pd.Index(ids_t, name="id"))
        else:
            if len(categories) != n_inst:
                msg = f"gold categories have {len(categories)} rows for {n_inst} instances"
                raise InvalidArgument(msg)
            cats = categories.copy()
            cats.index = pd.Index(ids_t, name="id")
        abst = _abstain_codes(abstain, n_inst)
        return cls(
            ids=ids_t,
            split=split,
            n_objects=n_obj,
            n_steps=n_st,
            obj_offsets=obj_off,
            obj_instance=obj_inst,
            initial_boxes=init,
            final_boxes=fin,
            final_positions=pos,
            moved=moved,
            n_moved=n_moved,
            step_offsets=step_off,
            step_instance=step_inst,
            actions=act,
            subjects=subj,
            references=ref,
            stepbox_offsets=sb_off,
            step_boxes=sboxes,
            stepbox_step=sb_step,
            stepbox_moved=sb_moved,
            image_size=size,
            categories=cats,
            source=source,
            index=index,
            abstain=abst,
        )

    @classmethod
    def from_episodes(
        cls,
        episodes: Iterable[Episode | SymbolicEpisode],
        *,
        split: str | None = None,
        source: str = "",
    ) -> GoldTable:
        """Gather the targets of ``episodes`` (rendered or symbolic-only) into one table."""
        ids: list[str] = []
        n_obj: list[int] = []
        n_st: list[int] = []
        init: list[F64] = []
        fin: list[F64] = []
        pos: list[F64] = []
        steps: list[tuple[int, int, int]] = []
        sboxes: list[F64] = []
        sizes: list[tuple[int, int]] = []
        cats: list[dict[str, Any]] = []
        abstain: list[str | None] = []
        phenomena: list[str | None] = []
        lookup = {a: i for i, a in enumerate(ACTIONS)}
        for item in episodes:
            ep = item if isinstance(item, Episode) else Episode(item)
            sym = ep.symbolic
            boxes = episode_boxes(ep)
            n, s = sym.num_objects, sym.num_steps
            if boxes.shape != (s + 1, n, 4):
                msg = (
                    f"episode {sym.id}: its boxes have shape {boxes.shape}; expected "
                    f"({s + 1}, {n}, 4) for {s} steps and {n} objects"
                )
                raise DataIntegrityError(msg)
            positions = episode_positions(ep)
            cam = episode_camera(ep)
            ids.append(sym.id)
            n_obj.append(n)
            n_st.append(s)
            init.append(boxes[0])
            fin.append(boxes[-1])
            pos.append(positions[-1])
            sboxes.append(boxes[1:].reshape(-1, 4))
            steps.extend((lookup[g.action], g.subject, g.reference) for g in sym.grounded)
            sizes.append((cam.width, cam.height))
            cats.append(sym.categories())
            abstain.append(_optional_text(sym, ep, "abstain"))
            phenomena.append(_optional_text(sym, ep, "phenomenon"))
        st = np.array(steps, dtype=np.int64).reshape(-1, 3)
        empty4 = np.zeros((0, 4))
        return cls.build(
            ids=ids,
            n_objects=np.array(n_obj, dtype=np.int64),
            n_steps=np.array(n_st, dtype=np.int64),
            initial_boxes=np.concatenate(init) if init else empty4,
            final_boxes=np.concatenate(fin) if fin else empty4,
            final_positions=np.concatenate(pos) if pos else np.zeros((0, 3)),
            actions=st[:, 0],
            subjects=st[:, 1],
            references=st[:, 2],
            step_boxes=np.concatenate(sboxes) if sboxes else empty4,
            image_size=np.array(sizes, dtype=np.int64).reshape(-1, 2),
            categories=_category_frame(cats, phenomena),
            split=split,
            source=source,
            abstain=abstain if any(abstain) else None,
        )


def _optional_text(sym: object, ep: object, name: str) -> str | None:
    """An episode's optional text attribute (on the symbolic episode or the episode);
    None where absent or empty."""
    for owner in (sym, ep):
        value = getattr(owner, name, None)
        if value:
            return str(value)
    return None


def _category_frame(cats: list[dict[str, Any]], phenomena: list[str | None]) -> pd.DataFrame:
    """The categories of every instance: :data:`CATEGORY_COLUMNS`, any further category
    the episodes report, and ``phenomenon`` where some episode has one."""
    columns = list(CATEGORY_COLUMNS)
    others = set().union(*cats) - {*columns, "phenomenon"} if cats else set()
    columns += sorted(others)
    frame = pd.DataFrame(cats, columns=columns)
    if any(phenomena):  # the semantics split's: an ordinary instruction is "none"
        frame["phenomenon"] = [p or "none" for p in phenomena]
    return frame


def _abstain_codes(abstain: Sequence[str | None] | NDArray[Any] | None,
                   n: int) -> NDArray[np.int8] | None:
    """Gold abstain values (or codes) as codes, checked; None for none at all."""
    if abstain is None:
        return None
    if isinstance(abstain, np.ndarray) and abstain.dtype.kind in "iu":
        codes = abstain.astype(np.int8)
    else:
        try:
            codes = np.array([ABSTAIN_CODES[str(v)] if v else 0 for v in abstain], dtype=np.int8)
        except KeyError as exc:
            msg = (f"gold abstain {exc.args[0]!r} is not one of {list(ABSTAIN_CODES)} "
                   "(or empty for an instruction that is carried out)")
            raise DataIntegrityError(msg) from exc
    if codes.shape != (n,):
        msg = f"gold abstain needs one value per instance ({n}), got shape {codes.shape}"
        raise InvalidArgument(msg)
    if n and (codes.min() < 0 or codes.max() > len(ABSTAIN_CODES)):
        msg = f"gold abstain codes must lie in 0..{len(ABSTAIN_CODES)}"
        raise InvalidArgument(msg)
    return codes


def _split_of(collection: object) -> str | None:
    value = getattr(collection, "split", None)
    return value if isinstance(value, str) and value else None


def load_episodes(
    path: str | Path, *, part: str | None = None
) -> tuple[Iterable[Episode], str | None]:
    """Episodes of a data file, without images, and the split id it records.

    A ``.jsonl`` file holds one symbolic episode per line (``SymbolicEpisode.to_dict``);
    anything else is opened with :func:`nsrmp_bench.storage.open` (a split root at its
    part ``part``), every shard's sha256 checked against the manifest (once per file
    identity in a process): gold whose bytes changed is refused, not scored.
    """
    p = Path(path)
    if not p.exists():
        msg = f"data file {str(p)!r} does not exist; pass the path of a split's data file"
        raise InvalidArgument(msg)
    if p.suffix == ".jsonl":
        return _read_symbolic_jsonl(p), None
    from nsrmp_bench.storage import open as open_storage

    collection = open_storage(p, part=part, verify=True)  # gold is what its manifest says
    return collection.iter_episodes(images=False), _split_of(collection)


def _read_symbolic_jsonl(path: Path) -> list[Episode]:
    out: list[Episode] = []
    with path.open("r", encoding="utf-8") as fh:
        for lineno, line in enumerate(fh, 1):
            if not line.strip():
                continue
            try:
                out.append(Episode(SymbolicEpisode.from_dict(json.loads(line))))
            except (ValueError, KeyError, TypeError) as exc:
                msg = (
                    f"{path}:{lineno}: not a symbolic episode ({exc}); each line must be "
                    "the JSON of SymbolicEpisode.to_dict()"
                )
                raise DataIntegrityError(msg) from exc
    return out


def load_gold(
    data: GoldTable | str | Path | Iterable[Episode | SymbolicEpisode],
    *,
    split: str | None = None,
    part: str | None = None,
) -> GoldTable:
    """A :class:`GoldTable` from a table, a data file path, or an iterable of episodes.

    ``split`` names the split when the data does not record it; ``part`` picks the part
    of a split root (see :func:`load_episodes`).
    """
    if isinstance(data, GoldTable):
        return data
    if isinstance(data, str | Path):
        episodes, recorded = load_episodes(data, part=part)
        return GoldTable.from_episodes(episodes, split=recorded or split, source=str(data))
    # An open collection (``nsrmp_bench.open``) knows its split and where it was read.
    known, root = getattr(data, "split", None), getattr(data, "root", None)
    return GoldTable.from_episodes(
        data, split=known if isinstance(known, str) and known else split,
        source=str(root) if root is not None else "")
