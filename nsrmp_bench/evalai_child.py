"""One EvalAI evaluation in a child process, so that it has a time limit.

:func:`nsrmp_bench.evalai.evaluate_phase` runs ``python -m nsrmp_bench.evalai_child`` with
the annotation file, the submission, the phase codename and the phases (JSON) as arguments,
and waits at most its time limit. The child prints one JSON object: ``{"result": ...}`` on
success, ``{"error": class name, "message": ...}`` for an error of the package; the parent
raises the same class with the same message.
"""

from __future__ import annotations

import json
import sys

__all__ = ["main"]


def main(argv: list[str]) -> int:
    """Evaluate ``argv = [annotation, submission, phase, phases_json]``; print the outcome."""
    from nsrmp_bench.errors import NSRMPError
    from nsrmp_bench.evalai import evaluate_in_process

    annotation, submission, phase, phases = argv
    try:
        out = evaluate_in_process(annotation, submission, phase, json.loads(phases))
    except NSRMPError as exc:
        print(json.dumps({"error": type(exc).__name__, "message": str(exc)}))
        return 2
    print(json.dumps({"result": out}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
