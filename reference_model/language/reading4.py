"""The reader of sentence structure on a program model (``nsrm-v4``, ``nmn-v4``).

:class:`StructureReadingModel` reads each instruction with
:func:`~.structure.read_structure` (steps, constraints, questions, corrections, ellipsis,
superlatives, what the world lacks), then nsrm-v3's front end reads the text the
structure leaves, and the v3 networks decode it step by step with three additions:

- a step whose base is "it" in an ellipsis ("..., then the green one on top of it") takes
  the previous step's subject as its base;
- a superlative (``extreme[side, rank]``) picks, among the objects the phrase's other
  words fit (the network's own reference scores within ``extreme_members`` of the best),
  the one ranked ``rank`` towards ``side`` on the positions before the step; too close to
  tell apart (the DSL's ``EXTREME_MARGIN``) is not feasible;
- the model abstains (``not feasible``) where its own grounding says the phrase fits no
  object (the best object's reference score, before normalising over the objects, under
  ``absent_score``) or two objects alike (the best two within ``ambiguous_margin`` in
  log-probability): a referent the scene lacks or cannot tell apart is never guessed.

A structure that asks for nothing (a prohibition, a question, a remark) predicts
``abstain: "no action"``; one naming a colour or shape the world lacks ``"not feasible"``.
Abstaining, nothing moves and the program is empty.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import torch
from torch import Tensor

from nsrmp_bench.dataset import shared_camera
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.instruction_check import check_instruction
from nsrmp_bench.reference_model.language.reading import EMPTY_READING, ReadingModel
from nsrmp_bench.reference_model.language.structure import (
    NOT_FEASIBLE,
    Structure,
    plain_phrases,
    read_structure,
)
from nsrmp_bench.reference_model.program.data import ProgramData, program_data
from nsrmp_bench.reference_model.program.inference import (
    Decoded,
    Oracle,
    decoded_predictions,
    legal_pairs,
)
from nsrmp_bench.reference_model.program.scene3d import TOP, move, project_boxes
from nsrmp_bench.reference_model.program.training import EpisodeBatch, pad_tokens
from nsrmp_bench.scoring.submission import Prediction

__all__ = ["StructureReadingModel", "StructureSettings"]

_AXES = {"left": (-1.0, 0.0), "right": (1.0, 0.0), "behind": (0.0, 1.0), "front": (0.0, -1.0)}


@dataclass(frozen=True)
class StructureSettings:
    """The structure reader's settings (fields of the v4 configs; selected on
    semantics-v1/train and val and paper-v2/val)."""

    structure: bool = True  # read sentence structure (False: nsrm-v3's reading)
    reader_steps: bool = True  # the reader's count of steps decides how many the splitter cuts
    absent_score: float = -1e9  # the best object's reference score under this: not feasible
    ambiguous_margin: float = 0.0  # best two objects within this (log-prob): not feasible
    extreme_members: float = 6.0  # objects within this of the best are the phrase's set
    phrase_fit: float = -12.0  # no object fits a plain phrase this well: absent (0: off)
    phrase_twice: float = -0.5  # two objects fit it this well: ambiguous (0: off)


@dataclass
class _Confidence:
    """Per episode, the lowest fit and the smallest margin over its steps' references."""

    fit: float = float("inf")
    margin: float = float("inf")
    extreme_unclear: bool = False
    # per plain phrase ("the red cube"): each object's fit (the least over its words)
    phrases: list[list[float]] = field(default_factory=list)


def _raw(step_model: Any) -> tuple[Tensor, Tensor] | None:
    """The last step's reference scores before normalising (subject, base), averaged over
    an ensemble's members; None where the step model keeps none."""
    members = list(getattr(step_model, "members", [step_model]))
    subj, base = [], []
    for m in members:
        raw = getattr(m, "raw_scores", None)
        if raw is None and hasattr(m, "subject"):  # NMN+: one per role attention
            s, b = getattr(m.subject, "raw_scores", None), getattr(m.base, "raw_scores", None)
            raw = None if s is None or b is None else (s, b)
        if raw is None:
            return None
        subj.append(raw[0])
        base.append(raw[1])
    return torch.stack(subj).mean(0), torch.stack(base).mean(0)


def _ranked(members: list[int], centres: np.ndarray, side: str, rank: int) -> int | None:
    """The member ranked ``rank`` towards ``side`` (None: too few members), as the DSL's
    ``extreme`` ranks them; on the estimated positions the model sees, the nearest
    neighbour may be closer than the DSL's ``EXTREME_MARGIN`` (4 cm) without the true
    positions being so: the model then takes the nearer, it does not abstain."""
    ax = _AXES[side]
    scored = sorted(((float(centres[j, 0] * ax[0] + centres[j, 1] * ax[1]), j)
                     for j in members), reverse=True)
    if len(scored) < rank:
        return None
    # no margin: the DSL's EXTREME_MARGIN is for the true positions; these are estimates
    return scored[rank - 1][1]


class StructureReadingModel(ReadingModel):
    """A program model behind the reader of sentence structure (see the module doc)."""

    last_confidence: list[_Confidence] | None = None

    def settings(self) -> StructureSettings:
        """The reader's settings: the config's (a v4 config holds them), else the defaults."""
        cfg = self.config
        return cfg if isinstance(cfg, StructureSettings) else StructureSettings()

    def structures(self, items: Sequence[Mapping[str, Any]]) -> list[Structure]:
        """The structure of each item's instruction."""
        out = []
        for it in items:
            text = check_instruction(it["inputs"].get("instruction"),
                                     f"the instruction of episode {it['id']!r}")
            try:
                out.append(read_structure(text))
            except InvalidArgument as exc:
                msg = f"episode {it['id']!r}: {exc}"
                raise InvalidArgument(msg) from exc
        return out

    def predict(self, items: Sequence[dict[str, Any]],
                oracle: Oracle | None = None) -> Iterator[Prediction]:
        camera = shared_camera(items)
        data, decoded, abstain = self._decode_abstain(items, oracle)
        ids = [str(it["id"]) for it in items]
        for pred, why in zip(decoded_predictions(ids, data, decoded, camera), abstain,
                             strict=True):
            yield pred if why is None else replace(pred, abstain=why)

    def abstentions(self, items: Sequence[dict[str, Any]]) -> list[str | None]:
        """Per item, its abstention (None: it acts)."""
        return self._decode_abstain(items)[2]

    def _decode(self, items: Sequence[dict[str, Any]],
                oracle: Oracle | None = None) -> tuple[ProgramData, Decoded]:
        data, decoded, _ = self._decode_abstain(items, oracle)
        return data, decoded

    def _decode_abstain(self, items: Sequence[dict[str, Any]], oracle: Oracle | None = None,
                        ) -> tuple[ProgramData, Decoded, list[str | None]]:
        cfg = self.settings()
        if not cfg.structure:
            data, decoded = super()._decode(items, oracle)
            return data, decoded, [None] * len(items)
        self.set_threads()
        structures = self.structures(items)
        front = self.front_end()
        texts = []
        for s in structures:
            reading = front.read(s.text) if s.abstain is None else None
            texts.append(reading.text if reading is not None and not reading.empty
                         else EMPTY_READING)
        read = [{**it, "inputs": {**it["inputs"], "instruction": t}}
                for it, t in zip(items, texts, strict=True)]
        data = program_data(read, self.vocab, self.model.rule)
        decoded, confidence = self._run(data, structures, oracle)
        self.last_confidence = confidence  # for selecting the settings (scripts/)
        abstain: list[str | None] = []
        for i, (s, c, t) in enumerate(zip(structures, confidence, texts, strict=True)):
            why = s.abstain
            if why is None and t == EMPTY_READING:
                why = "no action"
            if why is None and (c.extreme_unclear or c.fit < float(cfg.absent_score)
                                or c.margin < float(cfg.ambiguous_margin)):
                why = NOT_FEASIBLE
            for fits in c.phrases if why is None else []:
                ranked = sorted(fits, reverse=True)
                if (cfg.phrase_fit and ranked[0] < float(cfg.phrase_fit)) or (
                        cfg.phrase_twice and len(ranked) > 1
                        and ranked[1] >= float(cfg.phrase_twice)):
                    why = NOT_FEASIBLE
            if why is not None:
                decoded.steps[i] = []
                n = len(data.states[i])
                decoded.boxes[i] = np.zeros((0, n, 4))
                decoded.depths[i] = np.zeros((0, n))
                decoded.centres[i] = data.states[i].centres.copy()
            abstain.append(why)
        return data, decoded, abstain

    def _phrase_fits(self, text: str, feats: Tensor, n: int) -> list[list[float]]:
        """Each plain phrase's fit to each object: the least over its colour and shape words
        of the word's concept score (``concept . features + bias``, the mean over an
        ensemble's members); none where the step model has no word concepts (NMN+)."""
        step = self.model.step
        members = list(getattr(step, "members", [step]))
        if not all(hasattr(m, "concept") for m in members):
            return []
        out = []
        for p in plain_phrases(text):
            words = [w for w in (p.colour, p.shape) if w is not None]
            ids = [self.vocab.encode(w)[0] for w in words]
            if not ids or any(i <= 1 for i in ids):  # a word the networks never saw
                continue
            tok = torch.tensor(ids, dtype=torch.long)
            parts = feats[:n].chunk(len(members), -1)
            logit = torch.stack([
                torch.einsum("wd,nd->wn", m.concept(tok), f) + m.concept_bias(tok)
                for m, f in zip(members, parts, strict=True)]).mean(0)
            out.append(logit.min(0).values.tolist())
        return out

    def _cuts(self, tokens: list[list[int]], structures: Sequence[Structure]) -> list[list[int]]:
        """The splitter's cuts, or where the reader counts another number of steps (steps
        begin where actions begin), the splitter's most probable places for that many."""
        splitter = self.model.splitter
        cuts = splitter.cuts(tokens)
        if not self.settings().reader_steps:
            return cuts
        probs = torch.sigmoid(splitter(pad_tokens(tokens)))
        for i, (tok, s) in enumerate(zip(tokens, structures, strict=True)):
            if s.abstain is None and s.steps >= 1 and len(cuts[i]) + 1 != s.steps:
                peaks = splitter.peaks(probs[i, : len(tok)])
                cuts[i] = sorted(t for t, _ in peaks[: s.steps - 1])
        return cuts

    @torch.no_grad()
    def _run(self, data: ProgramData, structures: Sequence[Structure],
             oracle: Oracle | None, batch_size: int = 64) -> tuple[Decoded, list[_Confidence]]:
        """Decode as :func:`~nsrmp_bench.reference_model.program.inference.decode` does,
        with the structure's references and the grounding's confidence."""
        model, splitter, rule = self.model.step, self.model.splitter, self.model.rule
        model.eval()
        splitter.eval()
        oracle = oracle or Oracle()
        members_within = float(self.settings().extreme_members)
        out = Decoded()
        conf = [_Confidence() for _ in range(len(data))]
        for start in range(0, len(data), batch_size):
            rows = list(range(start, min(start + batch_size, len(data))))
            batch = EpisodeBatch(data, rows)
            cuts = ([oracle.cuts[r] for r in rows] if oracle.cuts is not None
                    else self._cuts(batch.tokens, [structures[r] for r in rows]))
            pieces = [[tok[a:b] for a, b in zip([0, *c], [*c, len(tok)], strict=True)]
                      for tok, c in zip(batch.tokens, cuts, strict=True)]
            sizes = self.perceived_sizes(batch.sizes, batch.mask)
            feats = model.features(batch.crops, batch.mask, sizes)
            n_obj = batch.mask.shape[1]
            for i, r in enumerate(rows):
                if structures[r].abstain is None:
                    conf[r].phrases = self._phrase_fits(structures[r].said, feats[i],
                                                        len(data.states[r]))
            centres = [data.states[r].centres.copy() for r in rows]
            previous = torch.zeros((len(rows), n_obj))
            on = [[-1] * len(data.states[r]) for r in rows]
            steps: list[list[tuple[int, int, int]]] = [[] for _ in rows]
            boxes: list[list[np.ndarray]] = [[] for _ in rows]
            depths: list[list[np.ndarray]] = [[] for _ in rows]
            for k in range(max(len(p) for p in pieces)):
                act = [i for i, p in enumerate(pieces) if len(p) > k]
                idx = torch.tensor(act, dtype=torch.long)
                toks = pad_tokens([pieces[i][k] for i in act])
                cen = torch.zeros((len(act), n_obj, 3))
                for j, i in enumerate(act):
                    cen[j, : len(centres[i])] = torch.from_numpy(centres[i]).float()
                s_lp, b_lp, a_lp = model.step(model.code(toks), toks, feats[idx], cen,
                                              previous[idx], batch.mask[idx])
                raw = _raw(model)
                for j, i in enumerate(act):
                    r = rows[i]
                    s = structures[r]
                    n = len(data.states[r])
                    action = int(a_lp[j].argmax())
                    if oracle.actions is not None and k < len(oracle.actions[r]):
                        action = oracle.actions[r][k]
                    forced: dict[str, int] = {}
                    if k > 0 and k in s.base_previous and steps[i]:
                        forced["base"] = steps[i][-1][1]
                    for ex in s.extremes:
                        if ex.step != k or raw is None:
                            continue
                        scores = (raw[0] if ex.role == "subject" else raw[1])[j, :n]
                        best = float(scores.max())
                        members = (list(range(n)) if ex.generic else
                                   [o for o in range(n)
                                    if float(scores[o]) >= best - members_within])
                        if len(members) < ex.rank:  # the best `rank` the words fit
                            members = [int(o) for o in torch.argsort(scores, descending=True)
                                       [: ex.rank]]
                        chosen = _ranked(members, centres[i], ex.side, ex.rank)
                        if chosen is None:
                            conf[r].extreme_unclear = True
                        else:
                            forced[ex.role] = chosen
                    legal = torch.from_numpy(legal_pairs(on[i], action, n_obj))
                    pair = s_lp[j][:, None] + b_lp[j][None, :]
                    pair = pair.masked_fill(torch.eye(n_obj, dtype=torch.bool), float("-inf"))
                    if "subject" in forced:
                        keep = torch.zeros(n_obj, dtype=torch.bool)
                        keep[forced["subject"]] = True
                        pair = pair.masked_fill(~keep[:, None], float("-inf"))
                    if "base" in forced:
                        keep = torch.zeros(n_obj, dtype=torch.bool)
                        keep[forced["base"]] = True
                        pair = pair.masked_fill(~keep[None, :], float("-inf"))
                    scores_pair = pair.masked_fill(~legal, float("-inf"))
                    if not bool(torch.isfinite(scores_pair).any()):
                        scores_pair = pair if bool(torch.isfinite(pair).any()) else (
                            s_lp[j][:, None] + b_lp[j][None, :])
                    subj, base = divmod(int(scores_pair.reshape(-1).argmax()), n_obj)
                    if oracle.grounding is not None and k < len(oracle.grounding[r]):
                        subj, base = oracle.grounding[r][k]
                    if raw is not None:
                        for role, lp, rs in (("subject", s_lp[j, :n], raw[0][j, :n]),
                                             ("base", b_lp[j, :n], raw[1][j, :n])):
                            if role in forced:
                                continue
                            if role == "subject" and k > 0 and bool(previous[i].any()) \
                                    and int(lp.argmax()) == int(previous[i].argmax()):
                                continue  # "it": the previous step's subject
                            top = torch.topk(lp, min(2, n)).values
                            conf[r].fit = min(conf[r].fit, float(rs.max()))
                            if n > 1:
                                conf[r].margin = min(conf[r].margin, float(top[0] - top[1]))
                    on[i][subj] = base if action == TOP else -1
                    state = data.states[r]
                    centres[i] = move(state, centres[i][None], np.array([subj]),
                                      np.array([base]), np.array([action]), rule)[0]
                    steps[i].append((action, subj, base))
                    boxes[i].append(project_boxes(state, centres[i]))
                    depths[i].append(state.camera.project(centres[i])[1])
                    previous[i] = 0.0
                    previous[i, subj] = 1.0
            for i, r in enumerate(rows):
                n = len(data.states[r])
                out.steps.append(steps[i])
                out.boxes.append(np.stack(boxes[i]) if boxes[i] else np.zeros((0, n, 4)))
                out.depths.append(np.stack(depths[i]) if depths[i] else np.zeros((0, n)))
                out.centres.append(centres[i])
        return out, conf
