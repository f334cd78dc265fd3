#!/usr/bin/env bash
# Quick start (1): set up .venv and run the default baseline evaluation
# (Navigation-v0, go-to-goal policy): a results table, results/*/summary.json,
# episodes.csv and trajectories.png. Extra arguments go to baselines.evaluate.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh train
.venv/bin/python -m baselines.evaluate "$@"
