#!/usr/bin/env bash
# Strict mypy over the whole nsrmp_bench namespace as installed, generators/ and
# reference_model/ included (scripts/installed_copy.sh says why a copy is checked).
#   scripts/mypy_installed.sh            (uses .venv/bin/pip and .venv/bin/mypy)
set -euo pipefail
exec "$(dirname "$0")/installed_copy.sh" bash -c \
  'MYPYPATH="$SITE" "$VENV/bin/mypy" --config-file "$REPO/pyproject.toml" -p nsrmp_bench'
