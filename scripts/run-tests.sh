#!/usr/bin/env bash
# The test command: installs what is missing, builds with warnings as errors and
# runs every test that belongs in the default run, then the sanitizer stages
# (scripts/run-sanitizers.sh): the unit and hostile-client tests under
# AddressSanitizer + UndefinedBehaviorSanitizer (build-asan; the release build
# leaves them out when that stage runs), and the daemon, capture, scheduler and
# API tests under ThreadSanitizer (build-tsan). Every build is a unity build
# (DFSM_UNITY_BUILD, CMakeLists.txt says why).
# docs/experiments/001-ci-durations.md has measured durations of each stage.
#
#   DFSM_TEST_LONG=1   also run the suites labelled "long"
#   DFSM_SANITIZE=0    skip both sanitizer stages (=asan or =tsan: only that one)
#   DFSM_FUZZ=1        also run the fuzz stage (clang + libFuzzer, build-fuzz)
#   DFSM_FUZZ_SECONDS  seconds each fuzz harness runs in it (default 20)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# Every stage prints its duration as it ends, and all of them at the end: CI has
# 90 minutes and the run is kept under 45.
durations=()
stage_start=$SECONDS
stage_done() {
  local line="$1: $((SECONDS - stage_start)) s"
  echo "== duration of $line"
  durations+=("$line")
  stage_start=$SECONDS
}
print_durations() {
  echo "== stage durations (total $SECONDS s):"
  local line
  for line in "${durations[@]}"; do echo "   $line"; done
}
trap print_durations EXIT

"$root/scripts/install-deps.sh"
stage_done "install-deps"
jobs="$(nproc)"

# arm64 and install-image-arm64 (qemu-user and qemu-system-aarch64, after
# scripts/build-deb.sh arm64) never run here.
exclude_labels="arm64|install-image-arm64"
[ "${DFSM_TEST_LONG:-0}" = 1 ] || exclude_labels="long|$exclude_labels"
exclude=(-LE "^($exclude_labels)\$")

# Architecture: api/ and daemon/service/ never include capture, nothing but
# tests/ depends on tests/, no cycle between folders (seconds).
"$root/scripts/check-architecture.sh"
stage_done "architecture"

# The unit and hostile-client tests run once: under ASan + UBSan when that stage
# runs (the release build then leaves them out: DFSM_OMIT_ASAN_TESTS), here
# otherwise. Always passed, so a reused build tree never keeps an old choice.
sanitize="${DFSM_SANITIZE:-1}"
omit_asan_tests=OFF
if [ "$sanitize" = 1 ] || [ "$sanitize" = asan ]; then omit_asan_tests=ON; fi

echo "== release build, -Werror (the ASan stage's tests left out: $omit_asan_tests)"
BUILD_DIR="$root/build" "$root/scripts/build.sh" \
  -DDFSM_WERROR=ON -DDFSM_BUILD_TESTS=ON -DDFSM_BUILD_BENCH=ON -DDFSM_TEST_CODE_FLAGS=-O2 \
  -DDFSM_UNITY_BUILD=ON -DDFSM_OMIT_ASAN_TESTS="$omit_asan_tests"
stage_done "release build"
(cd "$root/build" && ctest --output-on-failure --timeout 900 -j "$jobs" "${exclude[@]}")
stage_done "release tests"

# --- sanitizers ---
# asan: every test of the default run (labels unit, e2e, daemon, fuzz replays;
# not long, vm, soak) under ASan+UBSan; tsan: labels daemon and tsan under
# TSan. Reports of every process, dfsmd children included, are collected under
# <build>/sanitizer-reports and fail the stage. See scripts/run-sanitizers.sh.
case "$sanitize" in
  0) ;;
  asan | tsan) "$root/scripts/run-sanitizers.sh" "$DFSM_SANITIZE" ;;
  *) "$root/scripts/run-sanitizers.sh" asan tsan ;;
esac
stage_done "sanitizers (${DFSM_SANITIZE:-asan tsan})"
# --- end sanitizers ---

# --- fuzz ---
# The libFuzzer harnesses of fuzz/ (manifest, config, tar upload, frame
# conversion, every HTTP route), built with clang + ASan + UBSan into
# build-fuzz, each fuzzing its seed corpus for DFSM_FUZZ_SECONDS (default 20)
# (ctest label fuzz). Long campaigns: scripts/run-fuzz.sh. Off by default: a
# third sanitized build of the tree (clang) for 20 s of fuzzing per harness did
# not fit CI's 45 minutes, and the corpus and every past crash already replay
# under ASan+UBSan in the sanitizer stage (the *_replay tests, label unit).
# DFSM_FUZZ=1 runs it.
if [ "${DFSM_FUZZ:-0}" = 1 ]; then
  echo "== fuzz (libFuzzer, ${DFSM_FUZZ_SECONDS:-20} s per harness)"
  CC=clang CXX=clang++ cmake -S "$root" -B "$root/build-fuzz" -G Ninja \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDFSM_FUZZ=ON -DDFSM_FUZZ_SECONDS="${DFSM_FUZZ_SECONDS:-20}" \
    -DDFSM_BUILD_TESTS=OFF -DDFSM_BUILD_BENCH=OFF
  cmake --build "$root/build-fuzz" --parallel "$jobs" --target burst_manifest_fuzzer config_fuzzer \
    tar_upload_fuzzer frame_convert_fuzzer http_fuzzer
  (cd "$root/build-fuzz" && ctest --output-on-failure -j "$jobs" -L fuzz)
  stage_done "fuzz"
fi
# --- end fuzz ---

# --- capture: VM tests against the kernel's vivid driver (ctest label vm) ---
# Boots Debian's kernel under qemu (no KVM needed, ~3 min under emulation).
# Skipped, with the reason, where qemu or the kernel package cannot be had.
# DFSM_TEST_VM=0 skips it; the vm test skips itself unless DFSM_TEST_VM=1, so
# the default ctest run above does not boot the VM a second time.
if [ "${DFSM_TEST_VM:-1}" != 0 ]; then
  echo "== VM tests (vivid under qemu)"
  vm_packages=()
  while read -r line; do
    line="${line%%#*}"
    line="$(echo "$line" | xargs)"
    [ -z "$line" ] || dpkg-query -W -f='${Status}' "$line" 2>/dev/null | grep -q "install ok installed" ||
      vm_packages+=("$line")
  done <"$root/scripts/vm-packages.txt"
  if [ ${#vm_packages[@]} -gt 0 ] && [ "$(id -u)" -eq 0 ]; then
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      "${vm_packages[@]}" || echo "VM packages could not be installed: ${vm_packages[*]}"
  fi
  if command -v qemu-system-x86_64 >/dev/null && [ -x /bin/busybox ]; then
    (cd "$root/build" && DFSM_TEST_VM=1 ctest --output-on-failure --timeout 900 -L vm)
  else
    echo "VM tests skipped: qemu-system-x86_64 or busybox-static is not installed" \
      "(scripts/vm-packages.txt lists them; they could not be installed here)"
  fi
  stage_done "VM tests"
fi
# --- end capture ---
