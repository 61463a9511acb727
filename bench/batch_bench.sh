#!/bin/bash
# dfsm batch against a shell loop of dfsm process over the same generated
# bursts, side by side in one run; prints JSON. The bursts (VGA, 10 frames,
# 0.5 deg, seeds 1..N) are made once and kept in WORK.
#
#   bench/batch_bench.sh [BURSTS (64)] [WORK (/tmp/dfsm-batch-bench)]
#   DFSM=path/to/dfsm (default build/tools/dfsm/dfsm)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
dfsm="${DFSM:-$root/build/tools/dfsm/dfsm}"
bursts="${1:-64}" work="${2:-/tmp/dfsm-batch-bench}"
mkdir -p "$work/in"
for seed in $(seq "$bursts"); do
  [ -f "$work/in/burst-$seed/manifest.json" ] ||
    "$dfsm" synth --out "$work/in/burst-$seed" --width 640 --height 480 --rotation 0.5 \
      --seed "$seed" >/dev/null
done
now() { date +%s.%N; }

rm -rf "$work/loop" && mkdir -p "$work/loop"
start=$(now)
for seed in $(seq "$bursts"); do
  "$dfsm" process "$work/in/burst-$seed" --out "$work/loop/burst-$seed" >/dev/null 2>&1 || true
done
loop=$(awk -v a="$(now)" -v b="$start" 'BEGIN { print a - b }')

rm -rf "$work/batch"
jobs="$(nproc)"
start=$(now)
"$dfsm" batch "$work/in" --out "$work/batch" --jobs "$jobs" >/dev/null 2>&1 || true
batch=$(awk -v a="$(now)" -v b="$start" 'BEGIN { print a - b }')

ok=$(grep -c '"status":"ok"' "$work/batch/summary.jsonl" || true)
printf '{"bursts": %d, "cores": %d, "loop_s": %.2f, "batch_s": %.2f, "batch_jobs": %d, "ratio": %.3f, "batch_ok": %d}\n' \
  "$bursts" "$(nproc)" "$loop" "$batch" "$jobs" "$(awk -v a="$batch" -v b="$loop" 'BEGIN { print a / b }')" "$ok"
