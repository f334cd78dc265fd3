#!/usr/bin/env bash
# Run the whole test suite with every dependency at its declared lower bound: a second venv
# (default build/venv-floors, git-ignored; FLOORS_VENV overrides) gets teamgym and its extras
# installed with scripts/constraints-floors.txt as pip constraints, torch==2.13.0 first as in
# setup_env.sh. CI (.ci/run) runs this after scripts/run_tests.sh. Pytest arguments pass through.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${FLOORS_VENV:-build/venv-floors}"
constraints=scripts/constraints-floors.txt
python="${PYTHON:-python3.11}"
command -v "$python" >/dev/null 2>&1 || python=python3
if [ ! -x "$venv/bin/python" ]; then
  mkdir -p "$(dirname "$venv")"
  "$python" -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet torch==2.13.0 -c "$constraints"
"$venv/bin/python" -m pip install --quiet -e ".[train,dev,bench,gambit]" -c "$constraints"
export SDL_VIDEODRIVER=dummy MPLBACKEND=Agg TEAMGYM_FLOORS=1
"$venv/bin/python" -m pytest -q "$@"
