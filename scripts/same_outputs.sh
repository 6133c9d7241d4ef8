#!/usr/bin/env bash
# Runs two dexwarp binaries on the same inputs and says whether their outputs are the same,
# timing fields aside: every config of scenes/configs with `warp --threshold-mm 3.5`, contact
# IK and the baseline, and `augment --count 20 --seed 1` of every spec of scenes/variations.
# For a change that must not move what a user sees (a restructuring step): build the code
# before it and after it, then
#
#   bash scripts/same_outputs.sh BEFORE_BIN AFTER_BIN [WORK_DIR]
#
# Exits 0 when every file matches, 1 with the differing files listed otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
before=$(realpath "$1")
after=$(realpath "$2")
work=${3:-$(mktemp -d)}
mkdir -p "$work"
# Both binaries write into the same folder, moved aside after each run, so the paths that
# reports record are the same.
run() {
  local bin=$1 tag=$2
  rm -rf "$work/run" "$work/$tag"
  for config in scenes/configs/*.json; do
    name=$(basename "$config" .json)
    for hand in contact baseline; do
      "$bin" warp --config "$config" --threshold-mm 3.5 --hand "$hand" \
        --out "$work/run/warp/$name-$hand" >/dev/null 2>&1 || echo "$tag: warp $name $hand failed"
    done
  done
  for spec in scenes/variations/*.json; do
    name=$(basename "$spec" .json)
    demo=scenes/demos/${name%_stress}.demo.json
    "$bin" augment --demo "$demo" --variations "$spec" --count 20 --seed 1 \
      --out "$work/run/augment/$name" >/dev/null 2>&1 || echo "$tag: augment $name failed"
  done
  mv "$work/run" "$work/$tag"
}
run "$before" before
run "$after" after
# JSON compared with the fields that change between identical runs removed (times, the
# decomposition cache hit, the build's revision and version); other files byte for byte.
python3 - "$work/before" "$work/after" <<'PY'
import json, os, sys
VOLATILE = {"timing", "timing_s", "time_s", "build_s", "wall_s", "decomposition_cached",
            "git_revision", "tool"}
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if k not in VOLATILE}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v
def files(root):
    out = set()
    for d, _, names in os.walk(root):
        for n in names:
            if n != "index.html":
                out.add(os.path.relpath(os.path.join(d, n), root))
    return out
a, b = sys.argv[1], sys.argv[2]
fa, fb = files(a), files(b)
bad = sorted(fa ^ fb)
for f in sorted(fa & fb):
    pa, pb = os.path.join(a, f), os.path.join(b, f)
    if f.endswith(".json"):
        same = strip(json.load(open(pa))) == strip(json.load(open(pb)))
    else:
        same = open(pa, "rb").read() == open(pb, "rb").read()
    if not same:
        bad.append(f)
print(f"{len(fa | fb)} files, {len(bad)} differ")
for f in bad[:50]:
    print("  differs:", f)
sys.exit(1 if bad else 0)
PY
