#!/usr/bin/env bash
# Build .venv-vmas (git-ignored) for benchmarks/bench_vmas.py: VMAS (Vectorized Multi-Agent
# Simulator) beside torch==2.13.0, in a venv of its own. torch==2.13.0 goes first (the CPU build
# on local disk, as in setup_env.sh), then vmas with -c scripts/constraints-torch.txt so that pip
# never swaps in another torch (a multi-GB CUDA build). teamgym is not installed there: the
# benchmark runs its VMAS worker in this venv and everything else in .venv.
# Usage: bash scripts/setup_vmas_venv.sh [vmas version]   (default: 1.5.2, the release measured)
set -euo pipefail
cd "$(dirname "$0")/.."
version="${1:-1.5.2}"
python="${PYTHON:-python3.11}"
command -v "$python" >/dev/null 2>&1 || python=python3
constraints=scripts/constraints-torch.txt
venv=.venv-vmas
start=$SECONDS
if [ ! -x "$venv/bin/python" ]; then
  "$python" -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --upgrade pip -c "$constraints"
"$venv/bin/python" -m pip install --quiet torch==2.13.0 -c "$constraints"
"$venv/bin/python" -m pip install --quiet "vmas==$version" -c "$constraints"
"$venv/bin/python" -c "import torch, vmas; print(f'vmas {vmas.__version__}, torch {torch.__version__}')"
echo "== $venv: $((SECONDS - start)) s"
