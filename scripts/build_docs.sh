#!/usr/bin/env bash
# Build the documentation site (mkdocs.yml -> build/site) in its own venv (default build/venv-docs,
# git-ignored; DOCS_VENV overrides): torch==2.13.0 first (the CPU build on local disk, as in
# setup_env.sh), then teamgym editable with the docs extra at the floors pinned in
# scripts/constraints-floors.txt, then `mkdocs build --strict` (any warning fails the build).
# CI (.ci/run) runs this. Extra arguments go to mkdocs build.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${DOCS_VENV:-build/venv-docs}"
python="${PYTHON:-python3.11}"
command -v "$python" >/dev/null 2>&1 || python=python3
if [ ! -x "$venv/bin/python" ]; then
  mkdir -p "$(dirname "$venv")"
  "$python" -m venv "$venv"
fi
docs_pins="$(mktemp)"
trap 'rm -f "$docs_pins"' EXIT
grep -E '^(mkdocs-material|mkdocstrings)==' scripts/constraints-floors.txt >"$docs_pins"
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet torch==2.13.0
"$venv/bin/python" -m pip install --quiet -e '.[docs]' -c "$docs_pins"
"$venv/bin/python" -m mkdocs build --strict --site-dir build/site "$@"
