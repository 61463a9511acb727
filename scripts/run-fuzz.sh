#!/usr/bin/env bash
# A fuzzing campaign: builds the libFuzzer harnesses of fuzz/ (clang, into
# build-fuzz) and runs each for SECONDS_PER_HARNESS (default 300) on every
# core, one harness after the other, then prints the executions per harness
# and in total. The committed seed corpora are copied into a scratch directory
# first, so what the campaign finds never bloats the repository; crashes are
# listed at the end with the command that reproduces them (keep each one in
# fuzz/regressions/<harness>/ once fixed, see fuzz/README.md).
#
#   scripts/run-fuzz.sh [SECONDS_PER_HARNESS] [HARNESS...]
#   DFSM_FUZZ_JOBS=N    parallel fuzzing processes per harness (default: nproc)
#   DFSM_FUZZ_WORK=DIR  scratch directory (default: /tmp/dfsm-fuzz-campaign); its
#                       corpora grow from one campaign to the next
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds="${1:-300}"
shift || true
harnesses=("$@")
[ ${#harnesses[@]} -gt 0 ] || harnesses=(burst_manifest config tar_upload frame_convert http http_socket)
jobs="${DFSM_FUZZ_JOBS:-$(nproc)}"
work="${DFSM_FUZZ_WORK:-/tmp/dfsm-fuzz-campaign}"
build="$root/build-fuzz"

CC=clang CXX=clang++ cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DDFSM_FUZZ=ON -DDFSM_BUILD_TESTS=OFF -DDFSM_BUILD_BENCH=OFF >/dev/null
targets=()
for name in "${harnesses[@]}"; do targets+=("${name}_fuzzer"); done
cmake --build "$build" --parallel "$jobs" --target "${targets[@]}"

mkdir -p "$work"
summary="$work/summary.txt"
printf "%-16s %14s %8s %10s %8s\n" harness executions seconds exec/s crashes | tee "$summary"
total=0
for name in "${harnesses[@]}"; do
  corpus="$work/corpus/$name" logs="$work/logs/$name" artifacts="$work/artifacts/$name"
  rm -rf "$logs" "$artifacts"  # this campaign's crashes and logs only
  mkdir -p "$corpus" "$logs" "$artifacts"
  # http_socket shares the seeds and dictionary of http (fuzz/CMakeLists.txt:
  # CORPUS http).
  seeds="${name%_socket}"
  cp -n "$root/fuzz/corpus/$seeds/"* "$corpus/"
  [ -d "$root/fuzz/regressions/$name" ] && cp -n "$root/fuzz/regressions/$name/"* "$corpus/"
  dict=()
  [ -f "$root/fuzz/$seeds.dict" ] && dict=(-dict="$root/fuzz/$seeds.dict")
  start=$(date +%s)
  # -jobs writes one log per process (fuzz-N.log in the current directory);
  # each ends with its own final stats.
  (cd "$logs" && "$build/fuzz/${name}_fuzzer" -jobs="$jobs" -workers="$jobs" \
    -max_total_time="$seconds" -print_final_stats=1 -timeout=10 -rss_limit_mb=2048 \
    -artifact_prefix="$artifacts/" "${dict[@]}" "$corpus" >/dev/null 2>&1) || true
  elapsed=$(($(date +%s) - start))
  executed=$(cat "$logs"/fuzz-*.log 2>/dev/null |
    awk '/stat::number_of_executed_units:/ {sum += $2} END {print sum + 0}')
  crashes=$(find "$artifacts" -type f | wc -l)
  total=$((total + executed))
  printf "%-16s %14d %8d %10d %8d\n" "$name" "$executed" "$elapsed" \
    $((executed / (elapsed > 0 ? elapsed : 1))) "$crashes" | tee -a "$summary"
done
printf "%-16s %14d\n" total "$total" | tee -a "$summary"

found=$(for name in "${harnesses[@]}"; do find "$work/artifacts/$name" -type f; done | sort)
if [ -n "$found" ]; then
  echo "crashing inputs (reproduce: build-fuzz/fuzz/<harness>_fuzzer FILE):"
  echo "$found"
  exit 1
fi
