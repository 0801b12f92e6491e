#!/usr/bin/env bash
# Strict mypy over the whole nsrmp_bench namespace as installed, generators/ and
# reference_model/ included: the build maps those folders into the namespace, and mypy
# cannot follow an editable install's mapping, so a non-editable copy is checked instead.
#   scripts/mypy_installed.sh            (uses .venv/bin/pip and .venv/bin/mypy)
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
venv=${VENV:-$repo/.venv}
site=$(mktemp -d)
trap 'rm -rf "$site"' EXIT
"$venv/bin/pip" install -q --no-deps --no-build-isolation --target "$site/site" "$repo"
cd "$site"
MYPYPATH="$site/site" "$venv/bin/mypy" --config-file "$repo/pyproject.toml" -p nsrmp_bench
