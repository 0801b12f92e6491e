"""The robustness suite: models and baselines on every perturbation of one part.

For each kind, the part's perturbed copy (``perturb_part``, the suite's seed) is made once
under ``OUT/parts/<kind>``; every source (a learned model id, run with the caller's
``Runners.predict``, or a baseline id) writes its predictions on the unperturbed part and
on each copy (``OUT/predictions/<kind>--<source>.jsonl``), each file is scored by the
public scorer, and each perturbed file is compared with the unperturbed one, instance by
instance (``scoring.compare``: the paired mean difference with its bootstrap interval).
The table (``OUT/robustness.json``) has one row per source and kind: IoU-M and program
exact on both, the paired IoU-M difference with its 95% interval, and how many
instructions the kind changed. The oracle reads the gold program, not the instruction:
its row is 1.000 everywhere and shows that a perturbation left the gold untouched.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

from nsrmp_bench.baselines.registry import run_baseline
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.results.evaluate import Runners, Source, resolve_source
from nsrmp_bench.results.robustness_table import KindRow, Suite
from nsrmp_bench.robustness.kinds import CONTROLS, KINDS, lexicon
from nsrmp_bench.robustness.part import perturb_part
from nsrmp_bench.scoring.compare import compare
from nsrmp_bench.scoring.gold import load_episodes
from nsrmp_bench.scoring.result import ScoreResult
from nsrmp_bench.scoring.scorer import score
from nsrmp_bench.storage.atomic import atomic_write_text
from nsrmp_bench.storage.manifest import MANIFEST_NAME, Manifest, read_manifest

__all__ = ["CLEAN", "SUITE_SEED", "run_suite"]

SUITE_SEED = 0
"""The suite's test seed: the boards are made with it; models never train or select on
the parts it makes (augmentation uses other seeds and another lexicon)."""
CLEAN = "none"
"""The name of the unperturbed part in the suite's files."""

Say = Callable[[str], None]


def _part(data: Path, source: Manifest, out: Path, kind: str, seed: int, words: str,
          say: Say) -> Manifest:
    """The manifest of the perturbed copy of ``data`` (whose manifest is ``source``) for
    ``kind``: made, or the one already there when it is the same kind, seed and source."""
    part = out / "parts" / kind
    if (part / MANIFEST_NAME).exists():
        there = read_manifest(part)
        pert = there.perturbation or {}
        if (pert.get("kind"), pert.get("seed"), pert.get("source_root_hash"),
                pert.get("lexicon")) == (kind, seed, source.root_hash,
                                         lexicon(words)["version"]):
            return there
        msg = (f"{part} holds another perturbed part ({pert.get('kind')}, seed "
               f"{pert.get('seed')}, source {pert.get('source_root_hash')}); remove it or "
               "give another --out")
        raise InvalidArgument(msg)
    report = perturb_part(data, part, kind=kind, seed=seed, words=words)
    say(f"{kind}: {report.changed} of {report.count} instructions changed")
    return report.manifest


def _predict(source: Source, data: Path, pred: Path, runners: Runners) -> None:
    if source.kind == "baseline":
        episodes, recorded = load_episodes(data)
        run_baseline(source.name, episodes, pred, split=str(recorded))
        return
    if runners.predict is None:
        msg = f"{source.name} is a learned model: pass Runners(predict=...) to run it"
        raise InvalidArgument(msg)
    runners.predict(source.name, data, pred)


def run_suite(
    sources: Sequence[str], data: str | os.PathLike[str], out: str | os.PathLike[str], *,
    kinds: Sequence[str] = KINDS, seed: int = SUITE_SEED, words: str = "test",
    runners: Runners | None = None, say: Say | None = None, reuse: bool = False,
) -> Suite:
    """Every source on ``data`` and on its perturbation by each of ``kinds`` (with the word
    lists ``words``: ``test``, the suite's, or ``dev`` for selecting a model). With
    ``reuse`` a predictions file already in ``out`` is scored as it is, not written again
    (remove it to predict again)."""
    tell: Say = say if say is not None else (lambda _line: None)
    run_with = runners or Runners()
    bad = [k for k in kinds if k not in KINDS]
    kinds = [k for k in KINDS if k in kinds]  # the suite's order, whatever order was asked
    if bad:
        msg = f"kinds {bad}; expected some of {list(KINDS)}"
        raise InvalidArgument(msg)
    resolved = [resolve_source(s, run_with.models) for s in sources]
    files = [s for s in resolved if s.kind == "file"]
    if files:
        msg = (f"{files[0].path}: the suite runs models and baselines on parts it makes; for "
               "a predictions file of a perturbed part, use `nsrmp-bench compare` against "
               "your predictions on the unperturbed part")
        raise InvalidArgument(msg)
    data_p, out_p = Path(data), Path(out)
    manifest = read_manifest(data_p)
    if manifest.perturbation is not None:
        msg = f"{data_p} is a perturbed part; give the unperturbed one"
        raise InvalidArgument(msg)
    made = {k: _part(data_p, manifest, out_p, k, seed, words, tell) for k in kinds}
    parts = {CLEAN: data_p, **{k: out_p / "parts" / k for k in kinds}}
    (out_p / "predictions").mkdir(parents=True, exist_ok=True)
    rows: list[KindRow] = []
    for source in resolved:
        preds = {}
        for kind, part in parts.items():
            pred = out_p / "predictions" / f"{kind}--{source.name}.jsonl"
            if not (reuse and pred.exists()):
                _predict(source, part, pred, run_with)
            preds[kind] = pred
        clean = score(preds[CLEAN], data_p, breakdown=False)
        for kind in kinds:
            pert = made[kind].perturbation or {}
            result = score(preds[kind], parts[kind], breakdown=False)
            paired = compare(preds[kind], preds[CLEAN], data_p, n_perm=1000).table
            low, high = result.interval("iou_m")
            d = {k: float(paired.loc["iou_m", k])  # type: ignore[arg-type]
                 for k in ("diff", "ci_low", "ci_high", "p_value")}
            rows.append(KindRow(
                source=source.name, kind=kind, control=kind in CONTROLS,
                changed=int(pert.get("changed", 0)),
                count=int(pert.get("changed", 0)) + int(pert.get("unchanged", 0)),
                iou_m=result.headline, iou_m_low=low, iou_m_high=high,
                clean_iou_m=clean.headline, diff=d["diff"],
                diff_low=d["ci_low"], diff_high=d["ci_high"], p_value=d["p_value"],
                program_exact=result.value("program_exact"),
                clean_program_exact=clean.value("program_exact"),
                success=result.value("success"),
                **_strict(result, clean),
            ))
            tell(f"{source.name} on {kind}: IoU-M {result.headline:.3f}, paired "
                 f"{d['diff']:+.3f} [{d['ci_low']:+.3f}, {d['ci_high']:+.3f}]")
    suite = Suite(manifest.split, seed, manifest.root_hash, tuple(rows))
    out_p.mkdir(parents=True, exist_ok=True)
    suite.write(out_p / "robustness.json")
    atomic_write_text(out_p / "robustness.md", suite.markdown())
    return suite


def _strict(result: ScoreResult, clean: ScoreResult) -> dict[str, float]:
    """``scorer-v2``'s strict success and kept still on the perturbed and the unperturbed
    part (none under ``scorer-v1``)."""
    names = ("success_strict", "kept_still")
    if not all(m in result.summary.index and m in clean.summary.index for m in names):
        return {}
    return {**{m: result.value(m) for m in names},
            **{f"clean_{m}": clean.value(m) for m in names}}
