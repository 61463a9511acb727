#!/usr/bin/env bash
# arm64 against amd64 (issue 14, item 2; docs/packaging.md, "arm64"): the same
# burst, processed by the arm64 `dfsm process` of the arm64 package (under
# qemu-user, with the cross-build chroot's arm64 libraries, scripts/qemu-arm64.sh)
# and by the amd64 one, must give the same calibration and depth:
#
#   - focal length: |f_arm64 - f_amd64| / f_amd64 <= 0.1 %
#   - depth: `dfsm evaluate` of the arm64 depth map against the amd64 one as the
#     ground truth, and the other way round (a copy of the burst whose
#     ground_truth.json names the other map; evaluation.cc: textured pixels of
#     the reference frame, median scale), gives AbsRel <= 0.5 %, a median scale
#     within 0.5 % of 1 and a coverage >= 99 % in both directions.
#
#   tests/arm64/compare_test.sh AMD64_DFSM [WORK_DIR]    # default WORK_DIR /tmp/dfsm-arm64-compare
#
# The burst: `dfsm synth` (amd64) at 640x480, 10 frames (the arm64 process
# took 17 s under qemu on the 2-core development machine, the whole test 22 s).
#
#   DFSM_ARM64_DEB      the arm64 dfsm package (default: the newest out/deb/arm64/dfsm_*_arm64.deb,
#                       scripts/build-deb.sh arm64)
#   DFSM_ARM64_SYSROOT  arm64 libraries (default $DEB_CHROOT, else /var/cache/dfsm/cross-arm64)
#   DFSM_COMPARE_THREADS  worker threads of both runs (default 2)
#
# Exit status: 0 agree, 1 disagree or a run failed, 77 skipped (no arm64
# package, sysroot, qemu-aarch64, jq or textures: the reason is printed; under
# ctest, which sets DFSM_ARM64_CTEST=1, also unless DFSM_TEST_ARM64=1).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
skip() {
  echo "arm64_compare: SKIP: $*" >&2
  exit 77
}
log() { echo "arm64_compare: $*"; }
qemu_version() {
  { qemu-aarch64-static --version 2>/dev/null || qemu-aarch64 --version; } | head -1
}

[ $# -ge 1 ] || { echo "usage: $0 AMD64_DFSM [WORK_DIR]" >&2; exit 2; }
amd64_dfsm="$(realpath -m "$1")"
work="$(realpath -m "${2:-/tmp/dfsm-arm64-compare}")"
threads="${DFSM_COMPARE_THREADS:-2}"
sysroot="${DFSM_ARM64_SYSROOT:-${DEB_CHROOT:-/var/cache/dfsm/cross-arm64}}"
export DFSM_ARM64_SYSROOT="$sysroot"

if [ "${DFSM_ARM64_CTEST:-0}" = 1 ] && [ "${DFSM_TEST_ARM64:-0}" != 1 ]; then
  skip "the arm64 comparison runs dfsm under qemu-user (~25 s); set DFSM_TEST_ARM64=1 to run it (ctest -L '^arm64\$')"
fi
[ -x "$amd64_dfsm" ] || skip "no amd64 dfsm at $1 (build the target dfsm)"
command -v jq >/dev/null || skip "jq missing (apt-get install jq)"
command -v qemu-aarch64-static >/dev/null || command -v qemu-aarch64 >/dev/null ||
  skip "no qemu-aarch64 (apt-get install qemu-user-static)"
[ -e "$sysroot/lib/ld-linux-aarch64.so.1" ] ||
  skip "no arm64 sysroot at $sysroot (scripts/build-deb.sh arm64 makes it; DFSM_ARM64_SYSROOT names another)"
deb="${DFSM_ARM64_DEB:-$({ find "$root/out/deb/arm64" -maxdepth 1 -name 'dfsm_*_arm64.deb' -printf '%T@ %p\n' 2>/dev/null ||
  true; } | sort -nr | head -1 | cut -d' ' -f2-)}"
if [ -z "$deb" ] || [ ! -f "$deb" ]; then
  skip "no arm64 dfsm package (scripts/build-deb.sh arm64 writes out/deb/arm64/dfsm_*_arm64.deb; or set DFSM_ARM64_DEB)"
fi
[ -d /usr/share/doc/opencv-doc/examples/data ] ||
  skip "dfsm synth textures its scenes with opencv-doc's photographs (apt-get install opencv-doc)"

rm -rf "$work"
mkdir -p "$work"
dpkg-deb -x "$deb" "$work/arm64-pkg"
arm64_dfsm=("$root/scripts/qemu-arm64.sh" "$work/arm64-pkg/usr/bin/dfsm")
log "amd64: $amd64_dfsm"
log "arm64: $deb under qemu-user ($(qemu_version)), libraries of $sysroot"

# Each step prints its wall time.
step_start=$SECONDS
step_done() { log "$1: $((SECONDS - step_start)) s"; step_start=$SECONDS; }

# The burst, once, on amd64: both sides read the same files.
"$amd64_dfsm" synth --out "$work/burst" --width 640 --height 480 --frames 10 --seed 1 >/dev/null
step_done "synth (amd64)"
"$amd64_dfsm" process "$work/burst" --out "$work/amd64" --threads "$threads" >"$work/amd64.log" 2>&1 ||
  { cat "$work/amd64.log"; log "FAIL: amd64 process"; exit 1; }
step_done "process (amd64)"
"${arm64_dfsm[@]}" process "$work/burst" --out "$work/arm64" --threads "$threads" >"$work/arm64.log" 2>&1 ||
  { cat "$work/arm64.log"; log "FAIL: arm64 process"; exit 1; }
step_done "process (arm64, qemu-user)"

failures=0
check() {  # DESCRIPTION AWK_CONDITION: one verdict
  if awk "BEGIN {exit !($2)}"; then log "ok   $1"; else log "FAIL $1"; failures=$((failures + 1)); fi
}

for side in amd64 arm64; do
  [ "$(jq -r .status "$work/$side/result.json")" = ok ] || { log "FAIL: $side result status is not ok"; exit 1; }
  jq -e '.depth.file' "$work/$side/result.json" >/dev/null || { log "FAIL: $side result has no depth map"; exit 1; }
done
f_amd64="$(jq -r .calibration.fx "$work/amd64/result.json")"
f_arm64="$(jq -r .calibration.fx "$work/arm64/result.json")"
for key in fx k1 k2; do
  log "$key: amd64 $(jq -r ".calibration.$key" "$work/amd64/result.json"), arm64 $(jq -r ".calibration.$key" "$work/arm64/result.json")"
done
f_diff="$(awk -v a="$f_amd64" -v b="$f_arm64" 'BEGIN {d = (b - a) / a * 100; printf "%.6f", d < 0 ? -d : d}')"
check "focal length: |f_arm64 - f_amd64| / f_amd64 = ${f_diff} % <= 0.1 %" "$f_diff <= 0.1"

# Depth: one map as the other's ground truth. A copy of the burst whose
# ground_truth.json names that map (dfsm evaluate reads the frames, for the
# textured mask, and the depth file ground_truth.json names).
as_truth() {  # SIDE: writes $work/truth-SIDE
  local side="$1" file
  file="$(jq -r .depth.file "$work/$side/result.json")"
  cp -r "$work/burst" "$work/truth-$side"
  cp "$work/$side/$file" "$work/truth-$side/depth_$side.tiff"
  jq --arg d "depth_$side.tiff" '.depth = $d' "$work/burst/ground_truth.json" >"$work/truth-$side/ground_truth.json"
}
as_truth amd64
as_truth arm64
for pair in "arm64 amd64" "amd64 arm64"; do
  read -r estimate truth <<<"$pair"
  "$amd64_dfsm" evaluate --result "$work/$estimate" --truth "$work/truth-$truth" >"$work/$estimate-vs-$truth.json"
  abs_rel="$(jq -r '.depth.abs_rel * 100' "$work/$estimate-vs-$truth.json")"
  scale="$(jq -r .depth.scale "$work/$estimate-vs-$truth.json")"
  coverage="$(jq -r '.depth.coverage * 100' "$work/$estimate-vs-$truth.json")"
  pixels="$(jq -r .depth.evaluated_pixels "$work/$estimate-vs-$truth.json")"
  log "depth $estimate against $truth: AbsRel ${abs_rel} %, scale $scale, coverage ${coverage} %, $pixels pixels"
  check "depth AbsRel $estimate vs $truth ${abs_rel} % <= 0.5 %" "$abs_rel <= 0.5"
  check "depth scale $estimate vs $truth $scale within 0.5 % of 1" "$scale >= 0.995 && $scale <= 1.005"
  check "depth coverage $estimate vs $truth ${coverage} % >= 99 %" "$coverage >= 99"
  check "evaluated pixels $pixels > 0" "$pixels > 0"
done
# For the record: each against the burst's true depth and camera.
for side in amd64 arm64; do
  "$amd64_dfsm" evaluate --result "$work/$side" --truth "$work/burst" >"$work/$side-vs-truth.json"
  log "$side against the ground truth: f error $(jq -r .sparse.focal_error_percent "$work/$side-vs-truth.json") %," \
    "depth AbsRel $(jq -r '.depth.abs_rel * 100' "$work/$side-vs-truth.json") %," \
    "coverage $(jq -r '.depth.coverage * 100' "$work/$side-vs-truth.json") %"
done
step_done "comparison and evaluations (amd64)"
log "total: $SECONDS s"

if [ "$failures" -ne 0 ]; then
  log "FAIL ($failures); the results are in $work"
  exit 1
fi
log "PASS"
