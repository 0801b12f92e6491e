#!/usr/bin/env bash
# Run a command against a non-editable install of this repository: the build maps
# generators/ and reference_model/ into the nsrmp_bench namespace, which an editable
# install hides from tools that read files (mypy, import-linter). The copy is installed
# into a temporary folder, exported as $SITE (the folder holding nsrmp_bench), the command
# runs from its parent, and the folder is removed afterwards.
#   scripts/installed_copy.sh COMMAND [ARGS...]      (uses $VENV, default .venv)
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
venv=${VENV:-$repo/.venv}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$venv/bin/pip" install -q --no-deps --no-build-isolation --target "$tmp/site" "$repo"
export SITE="$tmp/site" REPO="$repo" VENV="$venv"
cd "$tmp"
"$@"
