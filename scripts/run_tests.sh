#!/usr/bin/env bash
# Quick start (2): set up .venv with the test dependencies and run the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh "train,dev,bench,gambit,fast"
export SDL_VIDEODRIVER=dummy MPLBACKEND=Agg
.venv/bin/python -m pytest -q "$@"
