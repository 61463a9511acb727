#!/bin/bash
# dfsm batch on a real Slurm: munged, slurmctld and slurmd started on this
# machine with a generated configuration (2 CPUs, every state, spool, log and
# socket under WORKDIR), deploy/slurm/dfsm-batch.sbatch submitted as an array
# of 3 shards over generated bursts, the shards' summaries merged, and every
# burst's result compared with 'dfsm process' run directly on it. Every
# daemon started is stopped on the way out. Skipped (exit 77) where Slurm or
# munge is not installed. Usage: slurm_test.sh DFSM WORKDIR
set -euo pipefail
dfsm="$(realpath "$1")" work="$2"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
for tool in munged slurmctld slurmd sbatch squeue scontrol; do
  if ! command -v "$tool" >/dev/null; then
    echo "SKIP: $tool is not installed (Debian: slurmctld slurmd slurm-client munge;" \
      "scripts/install-deps.sh installs them)"
    exit 77
  fi
done
rm -rf "$work" && mkdir -p "$work"/{state,spool,bursts,direct}
work="$(realpath "$work")"
pids=()
stop_all() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null || true
  done
}
trap stop_all EXIT
fail() {
  echo "FAIL: $1"
  for log in "$work"/*.log "$work"/out/dfsm-batch-*.out; do
    [ -f "$log" ] && { echo "--- $log"; tail -20 "$log"; }
  done
  exit 1
}
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }

# munge, on a key and socket of its own.
dd if=/dev/urandom of="$work/munge.key" bs=1024 count=1 status=none
chmod 600 "$work/munge.key"
munged --force --foreground --key-file="$work/munge.key" --socket="$work/munge.sock" \
  --pid-file="$work/munged.pid" --log-file="$work/munged.log" --seed-file="$work/munged.seed" \
  >"$work/munged.out" 2>&1 &
pids+=($!)

node="$(hostname -s)"
user="$(id -un)"
cat >"$work/slurm.conf" <<EOF
ClusterName=dfsmtest
SlurmctldHost=$node
SlurmUser=$user
SlurmdUser=$user
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$work/munge.sock
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
SlurmdTimeout=30
InactiveLimit=0
NodeName=$node CPUs=2 RealMemory=4096 State=UNKNOWN
PartitionName=test Nodes=$node Default=YES MaxTime=10 State=UP
EOF
export SLURM_CONF="$work/slurm.conf"
for _ in $(seq 50); do [ -S "$work/munge.sock" ] && break; sleep 0.1; done
[ -S "$work/munge.sock" ] || fail "munged did not start"
slurmctld -D -i >"$work/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -N "$node" >"$work/slurmd.out" 2>&1 &
pids+=($!)
for _ in $(seq 100); do
  sinfo -h -o %T 2>/dev/null | grep -qE '^(idle|mixed|allocated)' && break
  sleep 0.2
done
sinfo -h -o %T | grep -qE '^(idle|mixed|allocated)' || fail "the node did not come up: $(sinfo 2>&1)"

# Five bursts, one of them a tar as dfsmd serves it (<job>/burst.tar).
synth() { "$dfsm" synth --width 320 --height 240 --rotation 1 --supersampling 1 "$@" >/dev/null; }
for seed in 1 2 3 4; do synth --out "$work/bursts/burst-$seed" --seed "$seed"; done
synth --out "$work/job-5" --seed 5
mkdir -p "$work/bursts/job-5"
tar -C "$work/job-5" -cf "$work/bursts/job-5/burst.tar" .

mkdir -p "$work/out"
job=$(cd "$work/out" && DFSM="$dfsm" sbatch --parsable --array=0-2 \
  "$root/deploy/slurm/dfsm-batch.sbatch" "$work/out" "$work/bursts" --threads 1)
[ -n "$job" ] || fail "sbatch gave no job id"
for _ in $(seq 600); do
  [ -z "$(squeue -h -j "$job" 2>/dev/null)" ] && break
  sleep 0.25
done
[ -z "$(squeue -h -j "$job")" ] || fail "array job $job did not finish within 150 s"
for shard in 0 1 2; do
  [ -s "$work/out/summary.shard-$shard-of-3.jsonl" ] || fail "shard $shard wrote no summary"
done
"$dfsm" batch --merge "$work/out" --out "$work/out" >"$work/merge.log" || fail "merge failed"
[ "$(wc -l <"$work/out/summary.jsonl")" -eq 5 ] || fail "the merged summary does not list 5 bursts"
[ "$(grep -c '"status":"ok"' "$work/out/summary.jsonl")" -eq 5 ] || fail "not every burst ok"

# Each burst as dfsm process makes it directly: the same calibration, the
# same depth (byte for byte: one code, one thread per burst).
for seed in 1 2 3 4 5; do
  name="burst-$seed" input="$work/bursts/burst-$seed"
  [ "$seed" = 5 ] && name="job-5" input="$work/job-5"
  "$dfsm" process "$input" --out "$work/direct/$name" --threads 1 >/dev/null ||
    fail "dfsm process $name failed"
  python3 - "$work/out/$name" "$work/direct/$name" <<'EOF' || fail "$name differs from dfsm process"
import json, sys
a, b = (json.load(open(d + "/result.json")) for d in sys.argv[1:3])
for key in ("fx", "k1", "k2"):
    x, y = a["calibration"][key], b["calibration"][key]
    assert abs(x - y) <= 1e-9 * max(1.0, abs(y)), (key, x, y)
da, db = (open(d + "/depth.tiff", "rb").read() for d in sys.argv[1:3])
assert da == db, "depth.tiff differs"
EOF
done
echo "PASS: 5 bursts in 3 Slurm array tasks, merged, each as dfsm process makes it"
