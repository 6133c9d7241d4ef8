#!/usr/bin/env bash
# Combines the finished shards in OUT into OUT/stats.json, samples.csv, manifest.jsonl and
# index.html. Fails, naming the missing samples, while a shard is unfinished.
set -euo pipefail
DEXWARP=${DEXWARP:-dexwarp}
OUT=${OUT:-/shared/augment/mug}
exec "$DEXWARP" augment --merge "$OUT" --out "$OUT"
