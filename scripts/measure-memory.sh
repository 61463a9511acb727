#!/usr/bin/env bash
# Measures dfsmd's memory per resolution and configuration profile (issue 14,
# docs/memory.md): for each profile and size it generates a 10-frame burst
# (dfsm synth), starts dfsmd on a replay of it, waits until the ring is full,
# reads VmRSS, then runs JOBS capture jobs ({"frames":10,"when":"next"}) one
# after another and reads VmHWM, the kernel's peak resident set size of the
# process; once with glibc's default malloc arenas and once with
# MALLOC_ARENA_MAX=2 (the peak grows over the first jobs with the default:
# each thread that allocates gets an arena of its own). Prints a Markdown table.
#
#   scripts/measure-memory.sh [PROFILE.toml ...]   (default: config/dfsmd.toml config/dfsmd-1gb.toml)
#
#   SIZES     sizes to measure (default "640x480 1280x720 1920x1080")
#   JOBS      jobs per measurement (default 6; with glibc's default arenas the
#             peak still grows after 20 jobs, docs/memory.md)
#   ARENAS    MALLOC_ARENA_MAX values, "default" for glibc's own (default "default 2")
#   DFSMD     the daemon (default $BUILD_DIR/dfsmd/dfsmd, BUILD_DIR default build;
#             /usr/bin/dfsmd measures the installed package)
#   DFSM      the command-line tool, for synth (default $BUILD_DIR/tools/dfsm/dfsm)
#   WORK      bursts and state directories (default /tmp/dfsm-memory)
#   DFSMD_PORT  port of the API (default 18081)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
dfsmd="${DFSMD:-$build/dfsmd/dfsmd}"
dfsm="${DFSM:-$build/tools/dfsm/dfsm}"
work="${WORK:-/tmp/dfsm-memory}"
port="${DFSMD_PORT:-18081}"
jobs="${JOBS:-6}"
read -r -a arenas <<<"${ARENAS:-default 2}"
read -r -a sizes <<<"${SIZES:-640x480 1280x720 1920x1080}"
profiles=("$@")
[ ${#profiles[@]} -gt 0 ] || profiles=("$root/config/dfsmd.toml" "$root/config/dfsmd-1gb.toml")
api="http://127.0.0.1:$port"
for tool in "$dfsmd" "$dfsm"; do
  [ -x "$tool" ] || { echo "measure-memory: $tool not found (build first, or set DFSMD/DFSM)" >&2; exit 1; }
done
mkdir -p "$work"

pid=""
stop() {
  if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
    kill -TERM "$pid"
    for _ in $(seq 1200); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    # Still there after 2 min: the next measurement must not share its port.
    if kill -0 "$pid" 2>/dev/null; then kill -KILL "$pid"; fi
    wait "$pid" 2>/dev/null || true
  fi
  pid=""
}
trap stop EXIT

kib() { sed -n "s/^$1:[[:space:]]*\([0-9]*\) kB$/\1/p" "/proc/$pid/status"; }
mb() { awk -v k="$1" 'BEGIN { printf "%.0f", k * 1024 / 1e6 }'; }
json_field() { sed -n "s/.*\"$1\": *\"\{0,1\}\([^\",}]*\).*/\1/p" | head -1; }

# One measurement: profile $1, MALLOC_ARENA_MAX $2 ("default": unset), size $3.
measure() {
  local profile="$1" arena="$2" size="$3"
  local w="${size%x*}" h="${size#*x}"
  local burst="$work/burst-$size"
  [ -f "$burst/manifest.json" ] ||
    "$dfsm" synth --out "$burst" --width "$w" --height "$h" --frames 10 --seed 7 >/dev/null
  local state="$work/state-$(basename "$profile" .toml)-$arena-$size"
  rm -rf "$state"
  # Another daemon on the port (a dfsmd of an earlier run still finishing its
  # job) would answer the probes below in place of this one.
  if curl -fsS -o /dev/null "$api/healthz" 2>/dev/null; then
    echo "measure-memory: port $port is in use (set DFSMD_PORT)" >&2
    exit 1
  fi
  local log="$state.log"
  if [ "$arena" = default ]; then
    env -u MALLOC_ARENA_MAX "$dfsmd" --config "$profile" --capture.source "replay:$burst" \
      --jobs.state_dir "$state" --server.port "$port" >"$log" 2>&1 </dev/null &
  else
    MALLOC_ARENA_MAX="$arena" "$dfsmd" --config "$profile" --capture.source "replay:$burst" \
      --jobs.state_dir "$state" --server.port "$port" >"$log" 2>&1 </dev/null &
  fi
  pid=$!
  for _ in $(seq 300); do
    curl -fsS "$api/readyz" >/dev/null 2>&1 && break
    kill -0 "$pid" 2>/dev/null || { cat "$log" >&2; exit 1; }
    sleep 0.1
  done
  curl -fsS -o /dev/null "$api/readyz" || { echo "measure-memory: dfsmd not ready" >&2; cat "$log" >&2; exit 1; }
  # Streaming with the ring full: every preallocated slot written once.
  local camera fill="" capacity=""
  for _ in $(seq 600); do
    camera="$(curl -fsS "$api/api/v1/camera")"
    fill="$(echo "$camera" | json_field ring_fill)"
    capacity="$(echo "$camera" | json_field ring_capacity)"
    [ -n "$fill" ] && [ "$fill" = "$capacity" ] && break
    sleep 0.1
  done
  # Still this daemon (not one that failed to bind while another answered).
  kill -0 "$pid" 2>/dev/null || { echo "measure-memory: dfsmd exited" >&2; cat "$log" >&2; exit 1; }
  local idle
  idle="$(kib VmRSS)"
  local succeeded=0 total_ms=0 t0 location status
  for _ in $(seq "$jobs"); do
    t0="$(date +%s%N)"
    location="$(curl -fsS -D - -o /dev/null -X POST "$api/api/v1/captures" \
      -H 'Content-Type: application/json' -d '{"frames":10,"when":"next"}' |
      tr -d '\r' | sed -n 's/^Location: //Ip')"
    status=queued
    for _ in $(seq 6000); do
      status="$(curl -fsS "$api$location" | json_field status)"
      [ "$status" = succeeded ] || [ "$status" = failed ] && break
      sleep 0.1
    done
    total_ms=$((total_ms + ($(date +%s%N) - t0) / 1000000))
    if [ "$status" = succeeded ]; then
      succeeded=$((succeeded + 1))
    else
      echo "measure-memory: $size $(basename "$profile"): job $status" >&2
    fi
  done
  local peak
  peak="$(kib VmHWM)"
  printf '| %s | %s | %s x %s MB | %s | %s | %s | %s | %s/%s succeeded |\n' "$(basename "$profile")" \
    "$size" "$capacity" "$(awk -v w="$w" -v h="$h" 'BEGIN { printf "%.1f", w * h * 4 / 1e6 }')" \
    "$arena" "$(mb "$idle")" "$(mb "$peak")" \
    "$(awk -v t="$total_ms" -v n="$jobs" 'BEGIN { printf "%.1f", t / n / 1000 }')" "$succeeded" "$jobs"
  stop
}

printf '| profile | size | ring: frames x bytes | malloc arenas | RSS, ring full (MB) | peak RSS, VmHWM (MB) | job time (s) | jobs |\n'
printf '|---|---|---|---|---|---|---|---|\n'
for profile in "${profiles[@]}"; do
  "$dfsmd" --config "$profile" --capture.source synthetic: --check-config >/dev/null
  for arena in "${arenas[@]}"; do
    for size in "${sizes[@]}"; do
      measure "$profile" "$arena" "$size"
    done
  done
done
