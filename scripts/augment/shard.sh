#!/usr/bin/env bash
# One shard of a dexwarp augment run. Slurm arrays and Kubernetes Indexed Jobs run this once
# per index; every shard writes into the same shared folder, and `merge.sh` combines them.
#
#   DEMO, SPEC, COUNT, SEED, SHARDS, OUT   the run (defaults: the mug, 1000 samples, seed 1, 8 shards)
#   DEXWARP                               the binary (default: dexwarp on PATH)
#   JOBS                                  worker threads per shard (default: all cores)
# The index comes from SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX or INDEX, in that order.
set -euo pipefail
DEXWARP=${DEXWARP:-dexwarp}
DEMO=${DEMO:-scenes/demos/mug.demo.json}
SPEC=${SPEC:-scenes/variations/mug.json}
COUNT=${COUNT:-1000}
SEED=${SEED:-1}
SHARDS=${SHARDS:-8}
OUT=${OUT:-/shared/augment/mug}
JOBS=${JOBS:-0}
INDEX=${SLURM_ARRAY_TASK_ID:-${JOB_COMPLETION_INDEX:-${INDEX:?set SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX or INDEX}}}
exec "$DEXWARP" augment --demo "$DEMO" --variations "$SPEC" --count "$COUNT" --seed "$SEED" \
  --jobs "$JOBS" --out "$OUT" --shard "$INDEX/$SHARDS"
