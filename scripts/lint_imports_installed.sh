#!/usr/bin/env bash
# The layers of docs/architecture.md (pyproject's [tool.importlinter] contracts) checked with
# import-linter over the whole nsrmp_bench namespace as installed (scripts/installed_copy.sh
# says why a copy is checked).
#   scripts/lint_imports_installed.sh      (uses .venv/bin/pip and .venv/bin/lint-imports)
set -euo pipefail
exec "$(dirname "$0")/installed_copy.sh" bash -c \
  'PYTHONPATH="$SITE" "$VENV/bin/lint-imports" "$REPO/pyproject.toml"'
