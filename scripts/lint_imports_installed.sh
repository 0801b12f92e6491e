#!/usr/bin/env bash
# The layers of DESIGN.md (pyproject's [tool.importlinter] contracts) checked with
# import-linter over the whole nsrmp_bench namespace as installed: the build maps
# generators/ and reference_model/ into it, which an editable install hides from the
# import graph, so a non-editable copy is checked instead (as scripts/mypy_installed.sh does).
#   scripts/lint_imports_installed.sh      (uses .venv/bin/pip and .venv/bin/lint-imports)
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
venv=${VENV:-$repo/.venv}
site=$(mktemp -d)
trap 'rm -rf "$site"' EXIT
"$venv/bin/pip" install -q --no-deps --no-build-isolation --target "$site/site" "$repo"
cd "$site"
PYTHONPATH="$site/site" "$venv/bin/lint-imports" "$repo/pyproject.toml"
