#!/usr/bin/env bash
# The check to run before a release: a small export read, edited and trained on by the real
# libraries, LeRobot 0.4.4 and robomimic 0.3.0 from PyPI (check_loaders.py says what it
# checks). Not part of CI: the libraries and torch are gigabytes of wheels.
#
# usage: scripts/export/check_loaders.sh [WORK]
#   LOADERS_VENV  the venv with both libraries (default target/loaders-venv; made when it
#                 cannot import them; robomimic's egl_probe needs cmake to build)
set -euo pipefail
cd "$(dirname "$0")/../.."
venv=${LOADERS_VENV:-target/loaders-venv}
work=${1:-target/check-loaders}
if ! "$venv/bin/python" -c "import lerobot, robomimic" >/dev/null 2>&1; then
  command -v cmake >/dev/null || { echo "cmake is needed to build robomimic's egl_probe (apt-get install cmake)" >&2; exit 1; }
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q lerobot==0.4.4 robomimic==0.3.0
fi
cargo build --release --locked --features robomimic
bin=target/release/dexwarp
rm -rf "$work"
mkdir -p "$work"
# Four trajectories of the human hand: two configs, contact IK and the baseline.
for config in cube_messy teapot_pour_cups; do
  for hand in contact baseline; do
    "$bin" warp --config "scenes/configs/$config.json" --hand "$hand" --ensemble 2 \
      --out "$work/runs/$config-$hand"
  done
done
"$bin" export "$work/runs" --format lerobot --out "$work/lerobot"
"$bin" export "$work/runs" --format robomimic --out "$work/robomimic.hdf5"
# The libraries' own logs go to a file; the checks print one line each.
"$venv/bin/python" scripts/export/check_loaders.py "$work" 2>"$work/libraries.log" |
  grep -E "^(ok|FAILED|every)" || { echo "see $work/libraries.log" >&2; exit 1; }
