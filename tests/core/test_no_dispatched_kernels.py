"""No numpy transcendental ufunc where results reach stored bytes or decisions.

numpy dispatches ``np.sin``, ``np.arccos``, ``np.exp``, ... to SIMD kernels chosen by CPU
feature (SVML on AVX-512), whose last bits differ from libm's; generation and scoring use
``math.*`` (libm, what numpy itself calls without AVX-512) instead. A machine without
AVX-512 cannot show the difference by running, so this guards the sources.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CHECKED = ["generators", "nsrmp_bench/geometry", "nsrmp_bench/scoring", "nsrmp_bench/scene.py",
           "nsrmp_bench/baselines", "nsrmp_bench/storage"]
DISPATCHED = (
    "sin", "cos", "tan", "arcsin", "arccos", "arctan", "arctan2", "sinh", "cosh", "tanh",
    "arcsinh", "arccosh", "arctanh", "exp", "exp2", "expm1", "log", "log2", "log10", "log1p",
    "cbrt", "power", "float_power",
)
PATTERN = re.compile(r"\bnp\.(" + "|".join(DISPATCHED) + r")\(")


def test_generation_and_scoring_call_no_dispatched_transcendental() -> None:
    hits = []
    for entry in CHECKED:
        path = ROOT / entry
        for f in [path] if path.is_file() else sorted(path.rglob("*.py")):
            for n, line in enumerate(f.read_text("utf-8").splitlines(), 1):
                code = line.split("#", 1)[0]
                if PATTERN.search(code):
                    hits.append(f"{f.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not hits, "use math.* (libm) element by element instead:\n" + "\n".join(hits)
