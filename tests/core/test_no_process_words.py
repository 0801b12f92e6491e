"""No development diary in the product: the tracked text (README, docs, code and its
comments, model cards, JSON text fields, scripts) holds no work-log words: numbered
work-log entries, remarks on where or when a reading was taken, branch names, issue
numbers used as history; and every script or tool it names is in the repository. History
goes in CHANGELOG.md."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

# Data whose bytes are fixed (predictions scored by the boards, committed manifests,
# checkpoints) and files that are not text.
SKIP = re.compile(r"^(leaderboards/(site/)?predictions/|splits/manifests/)"
                  r"|\.(pt|png|svg|h5|mcap|parquet|jpg|gz|whl|ico|woff2?)$")

WORDS = {
    "a numbered work-log entry": r"\bstops? \d+(?:\s*[-–]\s*\d+)?\b",
    "a branch name": r"\bissue-\d+[a-z]?\b|\bbranch [`']?[\w-]+-\d+",
    "an issue number used as history": r"\bissues? #?\d+\b",
    "where a reading was taken": (
        r"\b(?:on |of )?(?:this|another|the other|the shared|the quiet|that)"
        r" (?:\d-core )?(?:machine|host)\b(?! of yours)"
        r"|\bshared \d-core machine\b|\bmeasured here\b|\(seen here\)|\bunmeasured here\b"),
    "when a reading was taken": r"\b(?:this|the last|an earlier|the previous) session\b",
}
PATTERN = re.compile("|".join(f"(?P<w{i}>{p})" for i, p in enumerate(WORDS.values())), re.I)
NAMES = list(WORDS)

# The project's own words that look like the above but say something about the product.
ALLOWED = re.compile(r"^$")

TOOL = re.compile(r"\b((?:scripts|tools|benchmarks)/[\w./-]+\.(?:py|sh|json))\b")


def tracked_text() -> dict[str, str]:
    """Every tracked text file but the fixed data, by repository path."""
    try:
        listed = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True,
                                check=True).stdout.decode().split("\0")
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout (git ls-files failed)")
    out = {}
    for rel in filter(None, listed):
        path = REPO / rel
        if SKIP.search(rel) or not path.is_file():
            continue
        data = path.read_bytes()
        if b"\0" in data:
            continue
        try:
            out[rel] = data.decode("utf-8")
        except UnicodeDecodeError:
            continue
    return out


def process_words(text: str) -> list[tuple[int, str, str]]:
    """(line, kind, the words) for every development-process word of ``text``."""
    found = []
    for m in PATTERN.finditer(text):
        if ALLOWED.search(m.group(0)):
            continue
        kind = NAMES[int(next(k for k, v in m.groupdict().items() if v is not None)[1:])]
        found.append((text.count("\n", 0, m.start()) + 1, kind, m.group(0)))
    return found


def test_the_patterns_find_what_they_are_for() -> None:
    stop, session = "st" + "op", "ses" + "sion"  # split so that this file holds no diary
    diary = (f"Where it stands ({stop}s 50-53): measured here on the shared machine, branch "
             f"`issue-28c`, as in issue 18; an earlier {session} read 0.9 ({stop} 47, another "
             "machine); 12 ms (seen here).")
    kinds = {k for _, k, _ in process_words(diary)}
    assert kinds == set(WORDS), kinds
    product = ("Stop the workers with Ctrl-C; `--workers N` local processes on the local "
               "machine; a step's stop condition; on a shared machine, timings are noisy.")
    assert process_words(product) == []


def test_no_development_process_words_in_tracked_text() -> None:
    me = str(Path(__file__).relative_to(REPO))
    problems = [f"{rel}:{line}: {kind}: {words!r}"
                for rel, text in tracked_text().items() if rel != me
                for line, kind, words in process_words(text)]
    assert not problems, ("development-process words in the product (history belongs in "
                          "CHANGELOG.md):\n" + "\n".join(problems))


# The leaderboard site's copies of the model cards, written by `nsrmp-bench leaderboard`
# from the cards this test reads at their source.
COPIES = re.compile(r"^leaderboards/site/model-cards/")


def test_every_script_named_is_in_the_repository() -> None:
    missing = sorted({f"{rel}: {m.group(1)}" for rel, text in tracked_text().items()
                      if not COPIES.match(rel)
                      for m in TOOL.finditer(text)
                      if not (REPO / m.group(1)).exists()})
    assert not missing, "names a script that is not in the repository:\n" + "\n".join(missing)
