#!/usr/bin/env bash
# Build the sdist and the wheel and check the wheel as a user gets it. `python -m build` (in its
# own venv, default build/venv-build; BUILD_VENV overrides) writes both to build/dist, the wheel
# built from the sdist. The wheel must hold every file git tracks under teamgym/ and baselines/
# (modules and package data: maps, graph maps and scenarios, presets, shipped agents, py.typed).
# It is installed in a new venv (default build/venv-wheel, made afresh each run; WHEEL_VENV
# overrides), torch==2.13.0 first as in setup_env.sh, and from a directory outside the repository
# (so the installed copy is imported, not the source tree) `import teamgym, baselines` must load
# from that venv and `python -m baselines.evaluate --env Navigation-v0 --episodes 2` must write
# its summary. CI (.ci/run) runs this.
set -euo pipefail
cd "$(dirname "$0")/.."
root="$PWD"
python="${PYTHON:-python3.11}"
command -v "$python" >/dev/null 2>&1 || python=python3
build_venv="${BUILD_VENV:-build/venv-build}"
wheel_venv="${WHEEL_VENV:-build/venv-wheel}"
dist=build/dist

if [ ! -x "$build_venv/bin/python" ]; then
  mkdir -p "$(dirname "$build_venv")"
  "$python" -m venv "$build_venv"
fi
"$build_venv/bin/python" -m pip install --quiet --upgrade pip build
rm -rf "$dist"
"$build_venv/bin/python" -m build --outdir "$dist" . >build/check_wheel_build.log 2>&1 || {
  tail -n 30 build/check_wheel_build.log
  exit 1
}
shopt -s nullglob
wheels=("$dist"/teamgym-*.whl)
sdists=("$dist"/teamgym-*.tar.gz)
if [ "${#wheels[@]}" -ne 1 ] || [ "${#sdists[@]}" -ne 1 ]; then
  echo "error: expected one wheel and one sdist in $dist, found: $(ls "$dist")" >&2
  exit 1
fi
wheel="$root/${wheels[0]}"
echo "built ${sdists[0]} and ${wheels[0]}"

# Every tracked file of the two packages is in the wheel.
git ls-files teamgym baselines >build/check_wheel_tracked.txt
"$build_venv/bin/python" - "$wheel" build/check_wheel_tracked.txt <<'EOF'
import sys
import zipfile

wheel, tracked = sys.argv[1], sys.argv[2]
names = set(zipfile.ZipFile(wheel).namelist())
files = [line for line in open(tracked).read().splitlines() if line]
missing = [f for f in files if f not in names]
if not files or missing:
    sys.exit(f"error: the wheel lacks {len(missing)} tracked file(s): {missing[:20]}")
data = [f for f in files if not f.endswith(".py")]
print(f"wheel holds all {len(files)} tracked files of teamgym/ and baselines/ ({len(data)} data files)")
EOF

rm -rf "$wheel_venv"
"$python" -m venv "$wheel_venv"
venv_python="$root/$wheel_venv/bin/python"
"$venv_python" -m pip install --quiet --upgrade pip
"$venv_python" -m pip install --quiet torch==2.13.0
"$venv_python" -m pip install --quiet "$wheel"

outside="$(mktemp -d)"
trap 'rm -rf "$outside"' EXIT
cd "$outside"
export SDL_VIDEODRIVER=dummy MPLBACKEND=Agg
"$venv_python" - "$root/$wheel_venv" <<'EOF'
import sys
from pathlib import Path

import baselines
import teamgym

venv = Path(sys.argv[1]).resolve()
for module in (teamgym, baselines):
    where = Path(module.__file__).resolve()
    if not where.is_relative_to(venv):
        sys.exit(f"error: {module.__name__} imported from {where}, not from the installed wheel in {venv}")
print(f"import teamgym, baselines: {Path(teamgym.__file__).parent.parent}")
EOF
"$venv_python" -m baselines.evaluate --env Navigation-v0 --episodes 2 --out "$outside/eval" --quiet
"$venv_python" - "$outside/eval/summary.json" <<'EOF'
import json
import sys

summary = json.load(open(sys.argv[1]))
if summary["episodes"] != 2:
    sys.exit(f"error: evaluate ran {summary['episodes']} episodes, not 2")
print(f"evaluate from the installed wheel: {summary['env']}, {summary['policy']}, 2 episodes, success rate {summary['success_rate']}")
EOF
