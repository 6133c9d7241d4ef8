#!/usr/bin/env bash
# Makes docs/player.png, the README's picture of the 3D player: warps mug_pass_wall, writes
# `dexwarp report` for it and screenshots the player in headless Chromium (the same browser
# and flags as the browser tests in tests/it/player.rs).
#
#   bash scripts/player_screenshot.sh            # uses `cargo run --release`
#   DEXWARP=target/debug/dexwarp bash scripts/player_screenshot.sh
set -euo pipefail
cd "$(dirname "$0")/.."
dexwarp() {
    if [[ -n "${DEXWARP:-}" ]]; then "$DEXWARP" "$@"; else cargo run --quiet --release -- "$@"; fi
}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
dexwarp warp --config scenes/configs/mug_pass_wall.json --out "$work/mug_pass_wall"
dexwarp report "$work/mug_pass_wall"
chromium --headless --no-sandbox --disable-gpu --no-first-run --hide-scrollbars \
    --user-data-dir="$work/profile" --window-size=1000,760 --virtual-time-budget=10000 \
    --screenshot="$PWD/docs/player.png" \
    "file://$work/mug_pass_wall/index.html#play=.&frame=300&only=1" 2>/dev/null
echo "wrote docs/player.png"
