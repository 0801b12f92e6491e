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


# The layers of docs/architecture.md (also pyproject's [tool.importlinter] contracts, checked over the
# installed namespace by scripts/lint_imports_installed.sh). Read here from the source
# folders as the build maps them, every import counted: module level, inside functions,
# and importlib.import_module / __import__ of a literal name.
REPO = ROOT.parent
FOLDERS = {"nsrmp_bench": REPO / "nsrmp_bench",
           "nsrmp_bench.generators": REPO / "generators",
           "nsrmp_bench.reference_model": REPO / "reference_model"}
# the applications, which import all: the command line, and the Gymnasium environment (it
# runs the world and, as policies, the learned models)
CORE_EXCEPT = ("nsrmp_bench.cli", "nsrmp_bench.envs")
FORBIDDEN = {
    "core": ("nsrmp_bench.generators", "nsrmp_bench.reference_model", "nsrmp_bench.cli"),
    "nsrmp_bench.generators": ("nsrmp_bench.reference_model", "nsrmp_bench.results",
                               "nsrmp_bench.cli"),
    # realise takes its placer (teleport, or the robot's, whose module imports realise)
    "nsrmp_bench.generators.world.realise": ("nsrmp_bench.generators.robot",
                                     "nsrmp_bench.reference_model", "nsrmp_bench.results",
                                     "nsrmp_bench.cli"),
    "nsrmp_bench.reference_model": ("nsrmp_bench.generators", "nsrmp_bench.cli"),
}


def _imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every import in ``path``, importlib calls of literals included."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(path.read_text("utf-8"))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found += [(node.lineno, f"{node.module}.{a.name}") for a in node.names]
        elif isinstance(node, ast.Call) and node.args:
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            arg = node.args[0]
            if (name in ("import_module", "__import__") and isinstance(arg, ast.Constant)
                    and isinstance(arg.value, str)):
                found.append((node.lineno, arg.value))
    return found


def _layer(module: str) -> str | None:
    for layer in ("nsrmp_bench.generators.world.realise", "nsrmp_bench.generators",
                  "nsrmp_bench.reference_model"):
        if module == layer or module.startswith(layer + "."):
            return layer
    if any(module == c or module.startswith(c + ".") for c in CORE_EXCEPT):
        return None
    return "core" if module.startswith("nsrmp_bench.") else None


def _sources() -> list[tuple[str, Path]]:
    out = []
    for package, folder in FOLDERS.items():
        for path in folder.rglob("*.py"):
            rel = path.relative_to(folder).with_suffix("").parts
            if package == "nsrmp_bench" and rel and rel[0] in ("generators", "reference_model"):
                continue
            parts = [p for p in rel if p != "__init__"]
            out.append((".".join([package, *parts]), path))
    return out


def test_layers_of_the_design_hold() -> None:
    broken = []
    for module, path in _sources():
        layer = _layer(module)
        if layer is None:
            continue
        for line, target in _imports(path):
            if any(target == f or target.startswith(f + ".") for f in FORBIDDEN[layer]):
                broken.append(f"{module} (line {line}) imports {target}")
    assert not broken, "layer violations:\n" + "\n".join(broken)


def test_the_layer_check_sees_hidden_imports(tmp_path: Path) -> None:
    src = tmp_path / "m.py"
    src.write_text("import importlib\n\ndef f():\n"
                   "    return importlib.import_module('nsrmp_bench.generators.templates')\n")
    assert (4, "nsrmp_bench.generators.templates") in _imports(src)


ROOT_NAMES = {"nsrmp_bench", "nsrmp_bench.__version__", "nsrmp_bench.open",
              "nsrmp_bench.score", "nsrmp_bench.load_model", "nsrmp_bench.serve"}


def test_no_module_imports_the_package_root() -> None:
    """The root's names imported on first use (``open``, ``score``, ``load_model``) reach
    every layer; a module that imported the root would reach them all too."""
    found = [f"{module} (line {line}) imports {target}"
             for module, path in _sources() if module != "nsrmp_bench"
             for line, target in _imports(path) if target in ROOT_NAMES]
    assert not found, ("import from the module itself (nsrmp_bench._version for "
                       "__version__):\n" + "\n".join(found))


def test_the_version_imports_nothing_else() -> None:
    import subprocess
    import sys

    code = ("import sys; from nsrmp_bench import __version__; "
            "extra = sorted(m for m in sys.modules if m.startswith('nsrmp_bench') "
            "and m not in ('nsrmp_bench', 'nsrmp_bench._version')); "
            "assert not extra, extra")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_every_module_is_in_a_layer_of_the_contract() -> None:
    """pyproject's ``layers`` contract names every top-level module and package of the
    namespace (a module outside every layer would escape the check)."""
    import tomllib

    config = tomllib.loads((REPO / "pyproject.toml").read_text("utf-8"))
    (contract,) = [c for c in config["tool"]["importlinter"]["contracts"]
                   if c["type"] == "layers"]
    named = {name.strip() for layer in contract["layers"]
             for name in layer.replace("|", ":").split(":")}
    present = {m.split(".")[1] for m, _ in _sources() if m.count(".") >= 1}
    assert present - named == set(), f"not in any layer: {sorted(present - named)}"
    assert named - present == set(), f"layers name missing modules: {sorted(named - present)}"
