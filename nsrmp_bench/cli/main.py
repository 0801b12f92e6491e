"""The ``nsrmp-bench`` command: one console script, one verb per module.

Each verb lives in ``nsrmp_bench/cli/<verb>.py`` (dashes become underscores) and provides
``add_arguments(parser)`` and ``run(args) -> int``. Verb modules are imported only when
their verb runs, so ``--help`` and scoring never import PyBullet or torch.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import sys
from collections.abc import Iterator, Sequence

from nsrmp_bench._optional import missing_extra
from nsrmp_bench._version import __version__
from nsrmp_bench.engine.signals import EXIT_SIGTERM, Terminated, sigterm_as_interrupt
from nsrmp_bench.errors import NSRMPError
from nsrmp_bench.storage.disk_faults import disk_fault

__all__ = ["VERBS", "main"]

VERBS: dict[str, str] = {
    "sample": "generate and print one symbolic episode as JSON",
    "show": "draw the contact sheet of a stored episode as a PNG",
    "generate": "generate (or resume) a split into HDF5 shards, deterministically",
    "verify": "recompute hashes and compare data with its manifest and the committed one",
    "info": "counts per category of a data directory or a split spec",
    "audit": "prove splits share no seed, scene or instance, and held-out material stays out",
    "pack": "write release files and the registry that download reads",
    "download": "fetch a split's shards from a mirror, verified against the registry",
    "export-mcap": "export stored episodes to MCAP (Foxglove schemas) for viewing",
    "import-nsrm": "convert the original NSRM release layout into nsrmp-bench shards",
    "import-original": "run the original authors' generator (pinned tree) into a TEST part",
    "score": "score a predictions file against a split's data",
    "compare": "paired comparison of two predictions files on the same split",
    "perturb": "a perturbed copy of a part (polite, typo, synonym, ...; blind and shuffled "
               "controls)",
    "robustness": "models on every perturbation of a part: paired IoU-M drops with intervals",
    "check-submission": "validate a predictions file without scoring it",
    "baseline": "write a non-learned baseline's predictions (oracle, noop, random)",
    "leaderboard": "rebuild the static leaderboards by scoring every committed entry",
    "challenge": "write an EvalAI challenge bundle (public and private test) for the scorer",
    "rollout": "run a policy in closed loop (Gymnasium env) on a part; write the achieved boxes",
    "serve": "serve a policy over WebSocket for `rollout --server` (its own process and venv)",
    "export-hf": "export a split as Hugging Face datasets Parquet shards with a dataset card",
    "export-lerobot": "export a split in the LeRobot v3.0 dataset layout",
    "replay": "carry out a predictions file with the simulated Panda; write the achieved boxes",
    "train": "train a learned model (nsrm, nmn, dense, detector, ...) on a split's train part",
    "predict": "write a learned model's predictions file for a split part",
    "reconstruct": "images of a predictions file's sub-goal states, with SSIM against gold",
    "detect": "write the detected initial objects of every episode of a split part",
    "score-detections": "detection metrics (COCO AP, recall, failed scenes) of a detections file",
    "evaluate": "score models and predictions files on every official test part",
    "plot": "draw the generalisation figures (PNG and SVG) of a results folder",
    "report": "the paper's Table I and II (markdown and LaTeX) from a results folder",
}
"""Verb name -> one-line help. The module is ``nsrmp_bench.cli.<verb with _>``."""

GROUPS: dict[str, tuple[str, ...]] = {
    "data": ("generate", "download", "verify", "info", "show", "sample", "export-mcap",
             "export-hf", "export-lerobot", "audit", "pack", "import-nsrm",
             "import-original"),
    "scoring": ("score", "check-submission", "compare", "baseline", "leaderboard", "challenge",
                "replay", "rollout", "serve"),
    "robustness": ("perturb", "robustness"),
    "learned models": ("predict", "train", "detect", "score-detections", "reconstruct"),
    "results": ("evaluate", "plot", "report"),
}
"""The verbs as the top-level help lists them, by what they are for."""

START_HERE = """start here (seconds; then the README and docs/):
  nsrmp-bench generate --split smoke-v2 --out data/smoke
  nsrmp-bench baseline noop --data data/smoke/test --out noop.jsonl
  nsrmp-bench score noop.jsonl --data data/smoke/test"""


def _grouped_verbs() -> str:
    width = max(len(v) for v in VERBS) + 2
    lines = [START_HERE, ""]
    for group, verbs in GROUPS.items():
        lines.append(f"{group}:")
        lines.extend(f"  {verb:<{width}}{VERBS[verb]}" for verb in verbs)
        lines.append("")
    lines.append("`nsrmp-bench VERB --help` shows a verb's options and examples.")
    return "\n".join(lines)


def _module_name(verb: str) -> str:
    return "nsrmp_bench.cli." + verb.replace("-", "_")


def build_parser(verb: str | None = None) -> argparse.ArgumentParser:
    """The argument parser; only ``verb``'s module is imported to add its arguments."""
    parser = argparse.ArgumentParser(
        prog="nsrmp-bench",
        description="Dataset and benchmark for language-guided robot manipulation "
        "with neuro-symbolic programs.",
        epilog=_grouped_verbs(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"nsrmp-bench {__version__}")
    sub = parser.add_subparsers(dest="verb", metavar="VERB",
                                help="what to do; the verbs are listed below by group")
    for name, help_text in VERBS.items():
        # no help= here: the grouped list in the epilog replaces argparse's single list
        p = sub.add_parser(name, description=help_text)
        if name == verb:
            importlib.import_module(_module_name(name)).add_arguments(p)
    return parser


def _missing(verb: str, exc: ImportError) -> int:
    """An optional package is not installed: its one-line message (any other import error
    is a bug and propagates)."""
    extra = missing_extra(exc)
    if extra is None:
        raise exc
    print(f"nsrmp-bench {verb}: error: {extra}", file=sys.stderr)
    return 2


LOG_WIDTH = 200
"""Columns of rich's tables and lines when output goes to a file or a pipe (a log)."""


@contextlib.contextmanager
def _log_width() -> Iterator[None]:
    """Output redirected to a log gets :data:`LOG_WIDTH` columns, not rich's 80, so that
    tables stay whole (no ``prog…``, no wrapped intervals); ``COLUMNS`` set by the user wins.
    rich reads ``COLUMNS`` when a console is made; it is restored afterwards."""
    if "COLUMNS" in os.environ or (sys.stdout.isatty() and sys.stderr.isatty()):
        yield
        return
    os.environ["COLUMNS"] = str(LOG_WIDTH)
    try:
        yield
    finally:
        os.environ.pop("COLUMNS", None)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    args_list = list(sys.argv[1:] if argv is None else argv)
    verb = next((a for a in args_list if not a.startswith("-")), None)
    try:
        parser = build_parser(verb if verb in VERBS else None)
    except ImportError as exc:  # a verb whose arguments need an optional package
        return _missing(str(verb), exc)
    args = parser.parse_args(args_list)
    if args.verb is None:
        parser.print_help()
        return 0
    try:
        module = importlib.import_module(_module_name(args.verb))
        with sigterm_as_interrupt(), _log_width():
            status: int = module.run(args)
    except NSRMPError as exc:
        print(f"nsrmp-bench {args.verb}: error: {exc}", file=sys.stderr)
        return 2
    except ImportError as exc:
        return _missing(args.verb, exc)
    except OSError as exc:  # a full disk, a read-only folder: a sentence; anything else raises
        sentence = disk_fault(exc)
        if sentence is None:
            raise
        print(f"nsrmp-bench {args.verb}: error: {sentence}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        by, status = (("SIGTERM", EXIT_SIGTERM) if isinstance(exc, Terminated)
                      else ("Ctrl-C", 130))
        print(f"nsrmp-bench {args.verb}: stopped by {by}; its workers are stopped and no "
              "file that looks complete is half-written; run the same command again (generate "
              "resumes where it stopped)", file=sys.stderr)
        return status
    return status


if __name__ == "__main__":
    raise SystemExit(main())
