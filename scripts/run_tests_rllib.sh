#!/usr/bin/env bash
# Run the Ray RLlib tests (pytest marker `rllib`: tests/baselines/test_rllib.py, test_rllib_batch.py, and tests/baselines/test_ray_cluster.py,
# which starts a two-node Ray cluster in a loopback-only Linux namespace) in their own venv (default
# build/venv-rllib, git-ignored; RLLIB_VENV overrides): ray[rllib] pins gymnasium==1.2.2, which
# neither .venv (latest gymnasium) nor the floor venv (gymnasium 1.0) can have. torch==2.13.0 is
# installed first (the CPU build on local disk, as in setup_env.sh), then teamgym with the rllib
# and dev extras and ray at its floor from scripts/constraints-floors.txt. CI (.ci/run) runs this
# after the latest and floor runs. Pytest arguments pass through (default: the two files).
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${RLLIB_VENV:-build/venv-rllib}"
python="${PYTHON:-python3.11}"
command -v "$python" >/dev/null 2>&1 || python=python3
if [ ! -x "$venv/bin/python" ]; then
  mkdir -p "$(dirname "$venv")"
  "$python" -m venv "$venv"
fi
ray_pin="$(grep -E '^ray==' scripts/constraints-floors.txt)"
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet torch==2.13.0
"$venv/bin/python" -m pip install --quiet -e ".[rllib,dev]" "$ray_pin"
export SDL_VIDEODRIVER=dummy MPLBACKEND=Agg RAY_USAGE_STATS_ENABLED=0
# Local clusters on 127.0.0.1: with this on (Ray's default on Linux) Ray binds and connects to the
# host's outward address even for ray.init() on one machine. tests/baselines/test_ray_cluster.py turns it back
# on for its own nodes, which run in a loopback-only namespace (joining a node needs it).
export RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0
if [ "$#" -eq 0 ]; then
  set -- tests/baselines/test_rllib.py tests/baselines/test_rllib_batch.py tests/baselines/test_ray_cluster.py
fi
"$venv/bin/python" -m pytest -q -m rllib "$@"
