#!/usr/bin/env bash
# Create or refresh the virtual environment .venv with teamgym and the given extras.
# torch is installed first, pinned to 2.13.0: pip takes that CPU build from the local
# disk; an unpinned torch (pulled in by stable-baselines3) would download a CUDA build.
# Usage: bash scripts/setup_env.sh [extras]   (default extras: train)
set -euo pipefail
cd "$(dirname "$0")/.."
extras="${1:-train}"
python="${PYTHON:-python3.11}"
command -v "$python" >/dev/null 2>&1 || python=python3
if [ ! -x .venv/bin/python ]; then
  "$python" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --quiet torch==2.13.0
.venv/bin/python -m pip install --quiet -e ".[${extras}]"
