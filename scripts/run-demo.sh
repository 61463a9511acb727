#!/usr/bin/env bash
# The main job: installs what is missing, builds, generates a small-motion burst
# with ground truth, starts the camera daemon dfsmd on a replay of it, takes one
# capture through the REST API, fetches and scores the results, and prints the
# curl lines to do it yourself. dfsmd keeps running afterwards (DFSM_DEMO_STOP=1
# stops it at the end).
#
#   DFSMD_PORT       port of the API (default 8080)
#   DFSM_DEMO_DIR    where the burst, state and results go (default out/demo)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/install-deps.sh" --runtime
export BUILD_DIR="${BUILD_DIR:-$root/build}"
# Unity batches as in CI and the package: the code tested is the code shipped,
# and the build takes about half the time of one file at a time.
"$root/scripts/build.sh" -DDFSM_BUILD_TESTS=OFF -DDFSM_BUILD_BENCH=OFF -DDFSM_UNITY_BUILD=ON
dfsm="$BUILD_DIR/tools/dfsm/dfsm"
dfsmd="$BUILD_DIR/dfsmd/dfsmd"
demo="${DFSM_DEMO_DIR:-$root/out/demo}"
port="${DFSMD_PORT:-8080}"
api="http://127.0.0.1:$port"
mkdir -p "$demo"

# A previous demo's daemon would hold the port.
if [ -f "$demo/dfsmd.pid" ]; then
  old="$(cat "$demo/dfsmd.pid")"
  if [ -n "$old" ] && [ "$(cat "/proc/$old/comm" 2>/dev/null)" = dfsmd ]; then
    echo "demo: stopping the previous demo's dfsmd (pid $old)"
    kill -TERM "$old"
    for _ in $(seq 100); do [ -d "/proc/$old" ] || break; sleep 0.1; done
  fi
  rm -f "$demo/dfsmd.pid"
fi

# The burst is generated now (no binaries in git): 640x480, 10 frames.
rm -rf "$demo/burst" "$demo/result"
"$dfsm" synth --out "$demo/burst" --width 640 --height 480 --frames 10 --seed 7

: >"$demo/dfsmd.log"
setsid "$dfsmd" --config "$root/config/dfsmd.toml" \
  --capture.source "replay:$demo/burst" --jobs.state_dir "$demo/state" \
  --server.port "$port" >>"$demo/dfsmd.log" 2>&1 </dev/null &
pid=$!
echo "$pid" >"$demo/dfsmd.pid"
for _ in $(seq 200); do
  curl -fsS "$api/readyz" >/dev/null 2>&1 && break
  if ! kill -0 "$pid" 2>/dev/null; then
    echo "demo: dfsmd did not start:" >&2
    cat "$demo/dfsmd.log" >&2
    exit 1
  fi
  sleep 0.1
done
curl -fsS "$api/readyz" >/dev/null || { echo "demo: dfsmd not ready" >&2; cat "$demo/dfsmd.log" >&2; exit 1; }
echo "demo: dfsmd (pid $pid) serves $api, log $demo/dfsmd.log"

# One capture: "next" 10 frames is one whole pass of the replayed burst, so
# the reference view is the one the ground truth describes.
location="$(curl -fsS -D - -o /dev/null -X POST "$api/api/v1/captures" \
  -H 'Content-Type: application/json' -d '{"frames":10,"when":"next"}' |
  tr -d '\r' | sed -n 's/^Location: //Ip')"
echo "demo: capture accepted, job $location"
status=queued
for _ in $(seq 1200); do
  status="$(curl -fsS "$api$location" | sed -n 's/^  "status": "\(.*\)",*$/\1/p')"
  [ "$status" = succeeded ] || [ "$status" = failed ] && break
  sleep 0.1
done
[ "$status" = succeeded ] || { echo "demo: job $status" >&2; curl -sS "$api$location" >&2; exit 1; }
mkdir -p "$demo/result"
for file in result.json depth.tiff depth.png preview.png confidence.png points.ply \
  calibration.json calibration.yaml; do
  curl -fsS -o "$demo/result/$file" "$api$location/$file"
done
# What came out, for a person: the camera, the depth, the time, the scores
# against the burst's ground truth ('dfsm evaluate' prints every metric as JSON).
echo
"$dfsm" show "$demo/result" --truth "$demo/burst"

cat <<EOT

Try it yourself (docs/daemon.md lists every endpoint):
  curl -si -X POST $api/api/v1/captures -H 'Content-Type: application/json' -d '{"frames":10,"when":"next"}'
  curl -s $api$location
  curl -s -o depth.png $api$location/depth.png
  curl -s $api/api/v1/jobs
  curl -s $api/api/v1/calibration
  curl -s $api/api/v1/camera
  curl -s -o snapshot.jpg $api/api/v1/snapshot.jpg
  curl -s $api/metrics
  tar -C $demo -cf burst.tar burst && curl -si -X POST $api/api/v1/jobs -H 'Content-Type: application/x-tar' --data-binary @burst.tar
EOT

if [ "${DFSM_DEMO_STOP:-0}" = 1 ]; then
  kill -TERM "$pid"
  for _ in $(seq 600); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  rm -f "$demo/dfsmd.pid"
  echo "demo: dfsmd stopped"
else
  echo
  echo "dfsmd keeps running (pid $pid); stop it with: kill $pid"
fi
