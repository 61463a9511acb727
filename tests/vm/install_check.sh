#!/bin/sh
# Runs inside the booted install-test image (install_test.sh), as the oneshot
# unit dfsm-install-check.service after dfsmd.service. Every line it prints
# starts with "install-check:" and goes to the serial console, which the host
# reads; the last is "install-check: RESULT PASS" or "... RESULT FAIL". Then
# it powers the VM off.
set -u
API=http://127.0.0.1:8080
DEV=/dev/video0
failures=0
now() { cut -d' ' -f1 /proc/uptime; }
log() { echo "install-check: $*"; }
pass() { log "ok   $*"; }
fail() { log "FAIL $*"; failures=$((failures + 1)); }
since() { echo "$(now) $1" | awk '{printf "%.1f", $1 - $2}'; }
# Top-level "status" of a job's JSON (routes.cc pretty-prints with 2 spaces).
status_of() { sed -n 's/^  "status": "\([a-z]*\)".*/\1/p'; }
finish() {
  log "boot to check start: ${boot_s} s (kernel + systemd; dfsmd active after ${dfsmd_active_s:-?} s)"
  log "total in the VM: $(now) s"
  if [ "$failures" -eq 0 ]; then log "RESULT PASS"; else log "RESULT FAIL ($failures)"; fi
  sync
  systemctl --no-block poweroff
  exit 0
}

boot_s=$(now)
log "start at ${boot_s} s of uptime; kernel $(uname -r); $(nproc) CPU; $(awk '/MemTotal/ {print $2 / 1024 " MiB"}' /proc/meminfo)"
log "dfsmd package: $(dpkg-query -W -f='${Package} ${Version} ${Status}' dfsmd 2>&1)"
# When dfsmd became active, and how long its start took (Type=notify: until
# READY=1, which the unit's TimeoutStartSec=30 bounds).
active_us=$(systemctl show -P ActiveEnterTimestampMonotonic dfsmd 2>/dev/null)
started_us=$(systemctl show -P InactiveExitTimestampMonotonic dfsmd 2>/dev/null)
if [ "${active_us:-0}" -gt 0 ] 2>/dev/null; then
  dfsmd_active_s=$(echo "$active_us" | awk '{printf "%.1f", $1 / 1e6}')
  log "dfsmd: start to READY=1 took $(echo "$active_us ${started_us:-0}" | awk '{printf "%.1f", ($1 - $2) / 1e6}') s (TimeoutStartSec=$(systemctl show -P TimeoutStartUSec dfsmd))"
fi

# --- 1. the service is active (started by systemd at boot: enabled at install)
t=$(now)
state=$(systemctl is-active dfsmd)
if [ "$state" = active ]; then pass "systemctl is-active dfsmd: active"; else
  fail "systemctl is-active dfsmd: $state"
  systemctl status --no-pager dfsmd 2>&1 | sed 's/^/install-check:   /'
  journalctl -b -u dfsmd --no-pager 2>&1 | tail -30 | sed 's/^/install-check:   /'
fi
# vivid came from modules-load.d, and udev gave its node to the group video.
[ -d /sys/module/vivid ] && pass "vivid loaded at boot (/etc/modules-load.d/dfsm-vivid.conf)" ||
  fail "vivid not loaded: $(systemctl is-active systemd-modules-load)"
node=$(stat -c '%G %a' $DEV 2>&1)
case "$node" in video\ 66*) pass "$DEV: group video, mode ${node#* }" ;; *) fail "$DEV: $node" ;; esac
# Ready: capture streams (GET /readyz 200), at most 120 s.
ready=""
for _ in $(seq 240); do
  code=$(curl -s -o /tmp/readyz -w '%{http_code}' $API/readyz)
  [ "$code" = 200 ] && { ready=1; break; }
  sleep 0.5
done
if [ -n "$ready" ]; then pass "GET /readyz 200 after $(since "$t") s"; else
  fail "GET /readyz: $code $(cat /tmp/readyz 2>/dev/null)"
fi
log "vivid: $(v4l2-ctl -d $DEV --get-fmt-video 2>&1 | tr -s ' \n' ' ' | cut -c1-160)"
curl -s $API/api/v1/camera 2>/dev/null | tr -s ' \n' ' ' | cut -c1-300 | sed 's/^/install-check: camera: /'
echo
log "duration of check 1 (active, ready): $(since "$t") s"

# --- 2. a capture: 202, the job succeeds with a depth map
capture() {  # V4L2_CONTROLS: sets vivid's controls, triggers a capture, waits for the job
  v4l2-ctl -d $DEV $1 2>&1 | sed 's/^/install-check: v4l2-ctl: /'
  sleep 2
  body='{"frames":6,"when":"next","planes":32}'
  code=$(curl -s -D /tmp/headers -o /tmp/post -w '%{http_code}' -X POST $API/api/v1/captures \
    -H 'Content-Type: application/json' -d "$body")
  location=$(sed -n 's/^[Ll]ocation: *\([^[:space:]]*\).*/\1/p' /tmp/headers | tr -d '\r')
  if [ "$code" = 202 ] && [ -n "$location" ]; then pass "POST /api/v1/captures $body: 202, Location $location"; else
    fail "POST /api/v1/captures: $code $(cat /tmp/post)"
  fi
  job_status=""
  if [ -n "$location" ]; then
    for _ in $(seq 1200); do
      job_status=$(curl -s $API$location | status_of)
      case "$job_status" in succeeded | failed) break ;; esac
      sleep 1
    done
  fi
  log "job $location ($1): $job_status after $(since "$t") s"
}
# vivid's 16x16 checkers scroll right by one pixel a frame under its text
# overlay, which stays put: the burst has image motion for the pipeline to
# track (vivid's default pattern stands still). Its calibration comes out
# "degenerate" (a flat pattern tells nothing of the lens), but the job succeeds
# with a dense depth map, which is what this test asks of the installed daemon.
t=$(now)
capture "-c test_pattern=10 -c horizontal_movement=4 -c osd_text_mode=0"
if [ "$job_status" = succeeded ]; then
  pass "job succeeded"
  curl -s $API$location >/tmp/job.json
  sed -n '/"timings_ms"/,/}/p' /tmp/job.json | tr -s ' \n' ' ' | sed 's/^/install-check: /'
  echo
  code=$(curl -s -o /tmp/depth.tiff -w '%{http_code}' $API$location/depth.tiff)
  magic=$(head -c 4 /tmp/depth.tiff | od -An -tx1 | tr -d ' \n')
  size=$(stat -c %s /tmp/depth.tiff 2>/dev/null || echo 0)
  case "$code:$magic" in
    200:49492a00 | 200:4d4d002a) pass "GET depth.tiff: 200, TIFF, $size bytes" ;;
    *) fail "GET depth.tiff: $code, magic $magic, $size bytes" ;;
  esac
  code=$(curl -s -o /tmp/result.json -w '%{http_code}' $API$location/result.json)
  if [ "$code" = 200 ] && grep -q '"depth' /tmp/result.json; then pass "GET result.json: 200"; else
    fail "GET result.json: $code"
  fi
  grep -E '"(valid_fraction|coverage|f|fx|quality)"' /tmp/result.json | head -5 | tr -s ' \n' ' ' | sed 's/^/install-check: result: /'
  echo
else
  fail "job status: ${job_status:-none}"
  curl -s $API$location 2>/dev/null | grep -E '"(error|stage)"' | sed 's/^/install-check:   /'
fi
log "duration of check 2 (capture to succeeded job and its depth map): $(since "$t") s"

# --- 3. a restart keeps the finished job
t=$(now)
systemctl restart dfsmd
state=$(systemctl is-active dfsmd)
[ "$state" = active ] && pass "systemctl restart dfsmd: active again after $(since "$t") s" ||
  fail "after systemctl restart dfsmd: $state"
after=""
if [ -n "$location" ]; then
  for _ in $(seq 120); do
    after=$(curl -s $API$location | status_of)
    [ -n "$after" ] && break
    sleep 0.5
  done
fi
if [ "$after" = succeeded ] && [ "$job_status" = succeeded ]; then pass "after the restart GET $location: succeeded"; else
  fail "after the restart GET $location: '${after}'"
fi
log "duration of check 3 (restart, job kept): $(since "$t") s"

# --- 4. apt-get remove stops the service and keeps the state directory
t=$(now)
job_id=${location##*/}
DEBIAN_FRONTEND=noninteractive apt-get remove -y dfsmd 2>&1 | grep -v 'Reading database' | tail -3 | sed 's/^/install-check: apt: /'
state=$(systemctl is-active dfsmd)
[ "$state" != active ] && pass "after apt-get remove dfsmd: is-active says $state" ||
  fail "after apt-get remove dfsmd: still $state"
running=""
for comm in /proc/[0-9]*/comm; do [ "$(cat "$comm" 2>/dev/null)" = dfsmd ] && running=1; done
[ -z "$running" ] && pass "no dfsmd process left" || fail "a dfsmd process is still running"
[ ! -e /usr/bin/dfsmd ] && pass "/usr/bin/dfsmd removed" || fail "/usr/bin/dfsmd still there"
if [ -d /var/lib/dfsmd ] && [ -f "/var/lib/dfsmd/jobs/$job_id/job.json" ]; then
  pass "/var/lib/dfsmd kept ($(ls -ld /var/lib/dfsmd | awk '{print $1, $NF}'); jobs/$job_id/job.json present)"
else
  fail "/var/lib/dfsmd or the job's record gone: $(ls -la /var/lib/dfsmd/ /var/lib/private/ 2>&1 | tr '\n' ' ')"
fi
[ -f /etc/dfsmd/dfsmd.toml ] && pass "/etc/dfsmd/dfsmd.toml kept (conffile)" || fail "/etc/dfsmd/dfsmd.toml gone"
log "duration of check 4 (apt-get remove): $(since "$t") s"
finish
