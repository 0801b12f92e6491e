"""No import cycles between the core's modules, counting imports inside functions too.

A cycle hidden behind a function-level import still ties two modules together (each needs
the other to work); the scorer's submission format and its checks once had one.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2] / "nsrmp_bench"


def _module_of(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _graph() -> dict[str, set[str]]:
    modules = {_module_of(p): p for p in ROOT.rglob("*.py")}
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for name, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text("utf-8"))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [f"{node.module}.{a.name}" for a in node.names] + [node.module]
            for t in targets:
                # the deepest module named (``from pkg import mod`` names ``pkg.mod``)
                while t and t not in modules:
                    t = t.rpartition(".")[0]
                if t and t != name and not name.startswith(t + "."):
                    graph[name].add(t)
    return graph


def _cycle_through(graph: dict[str, set[str]], start: str) -> list[str] | None:
    stack: list[tuple[str, list[str]]] = [(start, [start])]
    seen: set[str] = set()
    while stack:
        node, path = stack.pop()
        for nxt in sorted(graph[node]):
            if nxt == start:
                return [*path, start]
            if nxt not in seen:
                seen.add(nxt)
                stack.append((nxt, [*path, nxt]))
    return None


@pytest.mark.parametrize("package", ["nsrmp_bench.scoring", "nsrmp_bench.storage",
                                     "nsrmp_bench.dsl", "nsrmp_bench.geometry"])
def test_no_import_cycle_within(package: str) -> None:
    graph = _graph()
    inner = {m: {t for t in ts if t.startswith(package + ".")}
             for m, ts in graph.items() if m.startswith(package + ".")}
    cycles = [c for m in sorted(inner) if (c := _cycle_through(inner, m))]
    assert not cycles, f"import cycles in {package}: {cycles[0]}"
