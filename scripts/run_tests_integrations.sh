#!/usr/bin/env bash
# Run the tests of the integration stacks (docs/scale_out.md), each in its own venv
# build/venv-<stack> (git-ignored): torchrl, benchmarl (needs torchrl<0.12), tianshou, supersuit
# (with Stable-Baselines3 and sb3-contrib). Per stack: torch==2.13.0 first (the CPU build on local
# disk, as in setup_env.sh), then teamgym with the stack's extra and dev, the stack's package at
# its floor from scripts/constraints-floors.txt, every install with -c scripts/constraints-torch.txt
# (else pip may swap in a multi-GB CUDA torch); then the tests marked with the stack's name
# (tests/baselines/test_<stack>.py; TEAMGYM_STACK makes a failed import an error instead of a skip). Prints
# each stack's install and test seconds. CI (.ci/run) runs one stack per call.
# Usage: bash scripts/run_tests_integrations.sh [stack ...] [-- pytest arguments]   (default: all four)
set -euo pipefail
cd "$(dirname "$0")/.."
all=(torchrl benchmarl tianshou supersuit)
stacks=()
while [ "$#" -gt 0 ] && [ "$1" != "--" ]; do
  case " ${all[*]} " in
    *" $1 "*) stacks+=("$1") ;;
    *) echo "error: unknown stack '$1'; stacks are: ${all[*]}" >&2; exit 2 ;;
  esac
  shift
done
[ "${1:-}" = "--" ] && shift
[ "${#stacks[@]}" -eq 0 ] && stacks=("${all[@]}")
python="${PYTHON:-python3.11}"
command -v "$python" >/dev/null 2>&1 || python=python3
constraints=scripts/constraints-torch.txt
export SDL_VIDEODRIVER=dummy MPLBACKEND=Agg OMP_NUM_THREADS=1
status=0
for stack in "${stacks[@]}"; do
  venv="build/venv-$stack"
  start=$SECONDS
  if [ ! -x "$venv/bin/python" ]; then
    mkdir -p build
    "$python" -m venv "$venv"
  fi
  pin="$(grep -E "^$stack==" scripts/constraints-floors.txt)"
  "$venv/bin/python" -m pip install --quiet --upgrade pip -c "$constraints"
  "$venv/bin/python" -m pip install --quiet torch==2.13.0 -c "$constraints"
  "$venv/bin/python" -m pip install --quiet -e ".[$stack,dev]" "$pin" -c "$constraints"
  installed=$SECONDS
  TEAMGYM_STACK="$stack" "$venv/bin/python" -m pytest -q -p no:cacheprovider -m "$stack" "tests/baselines/test_$stack.py" "$@" || status=1
  echo "== $stack: install $((installed - start)) s, tests $((SECONDS - installed)) s"
done
exit "$status"
