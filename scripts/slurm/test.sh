#!/usr/bin/env bash
# The augment array on a real Slurm: a one-node controller and node daemon on this machine
# (Debian's slurm-wlm and munge, installed when missing), the product's own
# scripts/augment/slurm.sbatch and merge.sh submitted as docs/USAGE.md tells a user to, and
# the merged run compared with a one-machine augment of the same seed and count. Then one
# shard cancelled: the merge refuses and names the missing samples; that shard resubmitted
# and the merge again give the same result. The daemons are stopped on exit, whatever
# happened.
#
# usage: scripts/slurm/test.sh [BINARY]     (default target/release/dexwarp, built if missing)
# Needs root (the daemons). Without root or the packages it says so and skips, except under
# CI (CI set), where it fails.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$PWD
skip() {
  if [ -n "${CI:-}" ]; then
    echo "slurm test: $1 (CI must run it)" >&2
    exit 1
  fi
  echo "slurm test skipped: $1"
  exit 0
}
[ "$(id -u)" = 0 ] || skip "needs root to run the Slurm daemons"
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  command -v apt-get >/dev/null || skip "no slurm-wlm and munge, and no apt-get to install them"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null
fi
bin=$(realpath "${1:-target/release/dexwarp}")
[ -x "$bin" ] || { cargo build --release --locked; bin=$root/target/release/dexwarp; }

work=$(mktemp -d /tmp/dexwarp-slurm.XXXXXX)
pids=()
cleanup() {
  scancel --user=root >/dev/null 2>&1 || true
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for f in "$work"/slurmctld.pid "$work"/slurmd.pid "$work"/munged.pid; do
    [ -s "$f" ] && kill "$(cat "$f")" 2>/dev/null || true
  done
  sleep 1
  rm -rf "$work"
}
trap cleanup EXIT

# munge: a fresh key and socket of our own.
mkdir -p "$work/munge" "$work/spool/ctld" "$work/spool/d"
chmod 700 "$work/munge"
dd if=/dev/urandom of="$work/munge/munge.key" bs=1 count=1024 status=none
chmod 400 "$work/munge/munge.key"
munged --force --key-file="$work/munge/munge.key" --socket="$work/munge/munge.socket" \
  --pid-file="$work/munged.pid" --log-file="$work/munge/munged.log" \
  --seed-file="$work/munge/munged.seed"

host=$(hostname -s)
cpus=$(nproc)
mem=$(($(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 - 1024))
cat >"$work/slurm.conf" <<CONF
ClusterName=dexwarp-test
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$work/spool/ctld
SlurmdSpoolDir=$work/spool/d
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
JobAcctGatherType=jobacct_gather/none
MpiDefault=none
ReturnToService=2
NodeName=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF=$work/slurm.conf
slurmctld -i
slurmd
for _ in $(seq 60); do
  [ "$(sinfo -h -o %t 2>/dev/null)" = idle ] && break
  sleep 1
done
[ "$(sinfo -h -o %t)" = idle ] || { echo "the node did not come up:" >&2; tail -20 "$work"/slurm*.log >&2; exit 1; }
echo "slurm: one node ($host, $cpus cores) idle"

# Waits for job $1 to leave the queue, at most $2 seconds.
wait_job() {
  for _ in $(seq "$2"); do
    squeue -h -j "$1" 2>/dev/null | grep -q . || return 0
    sleep 1
  done
  echo "job $1 still queued after $2 s" >&2
  squeue >&2
  return 1
}
# A finished job's state (the controller keeps it for MinJobAge, 300 s; no accounting here).
state() { scontrol show job -o "$1" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | cut -d= -f2; }

# The run, as a user would override it: the count, the folder, the binary.
export COUNT=16 SEED=1 OUT=$work/run DEXWARP=$bin
export DEMO=scenes/demos/mug.demo.json SPEC=scenes/variations/mug.json
"$bin" augment --demo "$DEMO" --variations "$SPEC" --count "$COUNT" --seed "$SEED" \
  --jobs "$cpus" --out "$work/one" 2>/dev/null

# 1. The array and the merge after it, as docs/USAGE.md says.
jid=$(sbatch --parsable --output="$work/augment-%A_%a.log" scripts/augment/slurm.sbatch)
mid=$(sbatch --parsable --output="$work/merge-%j.log" --dependency=afterok:"$jid" scripts/augment/merge.sh)
wait_job "$jid" 600
wait_job "$mid" 120
cat "$work"/augment-*.log >"$work/shards.log"
if grep -qi "error" "$work/shards.log"; then
  echo "a shard's log has an error:" >&2
  grep -i error "$work/shards.log" >&2
  exit 1
fi
[ -f "$OUT/stats.json" ] || { echo "the merge did not run:" >&2; cat "$work"/merge-*.log >&2; exit 1; }
same() {
  python3 - "$1" "$2" <<'PY'
import csv, json, sys
from pathlib import Path
a, b = Path(sys.argv[1]), Path(sys.argv[2])
def stats(p):
    s = json.loads((p / "stats.json").read_text())
    for k in ("timing", "shards", "out", "samples_per_hour", "run_now", "already_finished"):
        s.pop(k, None)
    return s
def rows(p):
    return list(csv.DictReader(open(p / "samples.csv")))
if stats(a) != stats(b):
    sys.exit(f"stats.json differs: {stats(a)} against {stats(b)}")
if rows(a) != rows(b):
    sys.exit("samples.csv differs")
folders = sorted(d.name for k in ("kept", "failed") for d in (a / k).glob("*") if d.is_dir())
if len(folders) != len(set(folders)):
    sys.exit("a sample folder is there twice")
print(f"merged run equals the one-machine run: {len(rows(a))} samples, {len(folders)} folders")
PY
}
same "$OUT" "$work/one"

# 2. One shard cancelled: the merge refuses and names what is missing.
rm -rf "$OUT"
jid=$(sbatch --parsable --hold --output="$work/augment2-%A_%a.log" scripts/augment/slurm.sbatch)
scancel "${jid}_3"
scontrol release "$jid"
wait_job "$jid" 600
mid=$(sbatch --parsable --output="$work/merge2-%j.log" scripts/augment/merge.sh)
wait_job "$mid" 120
[ "$(state "$mid")" = FAILED ] || { echo "the merge did not refuse a missing shard ($(state "$mid")):" >&2; cat "$work/merge2-$mid.log" >&2; exit 1; }
grep -q "missing" "$work/merge2-$mid.log" || { echo "the refusal names nothing missing:" >&2; cat "$work/merge2-$mid.log" >&2; exit 1; }
echo "cancelled shard: the merge refused: $(grep -m1 missing "$work/merge2-$mid.log")"

# 3. That shard resubmitted, then the merge: the same run.
rid=$(sbatch --parsable --array=3 --output="$work/augment3-%A_%a.log" scripts/augment/slurm.sbatch)
mid=$(sbatch --parsable --output="$work/merge3-%j.log" --dependency=afterok:"$rid" scripts/augment/merge.sh)
wait_job "$rid" 300
wait_job "$mid" 120
same "$OUT" "$work/one"
echo "slurm test passed"
