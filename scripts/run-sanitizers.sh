#!/usr/bin/env bash
# The sanitizer stages of scripts/run-tests.sh (which runs them after the
# release build and its tests, unless DFSM_SANITIZE=0). Also usable alone,
# after scripts/install-deps.sh:
#
#   scripts/run-sanitizers.sh [asan] [tsan]     (no argument: both)
#
# in build-asan and build-tsan (DFSM_ASAN_BUILD_DIR, DFSM_TSAN_BUILD_DIR move them).
#
#   asan  build-asan: -O1 -g1, -fsanitize=address,undefined (errors are
#         fatal: -fno-sanitize-recover=all), only the target asan_tests (the
#         test binaries labelled unit or hostile); runs those labels: the API,
#         the daemon's service and dfsmd's routes in process, the hostile
#         clients, the fuzz corpus replays. Leak checking on. Left out, each
#         run once elsewhere: the e2e accuracy suites (3-5 min each under ASan,
#         the same code as the unit tests on larger images; the release stage
#         asserts their accuracy), and the dfsmd process tests (daemon,
#         browser: the same routes and jobs the in-process tests drive, here
#         through a child process; they run in the release stage and under
#         TSan, where their threads matter). Their binaries are not built.
#   tsan  build-tsan: -O2 -g1, -fsanitize=thread, only the target
#         tsan_tests (the test binaries labelled daemon or tsan, and dfsmd);
#         runs those labels: every dfsmd end-to-end test and the
#         unit tests of daemon/capture, daemon/service and api. OpenCV runs
#         serially in this build (cmake/tsan_serial_opencv.cc: its TBB pool is
#         invisible to TSan); the few third-party false positives left are
#         suppressed in scripts/tsan.supp, each entry with its reason. Races
#         in our code are fixed, never suppressed.
#
# docs/experiments/001-ci-durations.md has measured durations of each stage.
#
# Every sanitized process writes its report to <build>/sanitizer-reports/
# (log_path), dfsmd children included: the daemon tests send a child's stderr
# to a log they delete, and kill some children with SIGKILL, so a report would
# otherwise be lost. A stage fails when a test fails or when any report exists;
# the reports are printed at the end of the stage.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
jobs="$(nproc)"
stages=("$@")
[ ${#stages[@]} -gt 0 ] || stages=(asan tsan)

# Prints the reports under $1 and fails when there are any.
check_reports() {
  local reports=("$1"/*)
  [ -e "${reports[0]}" ] || return 0
  echo "sanitizer reports (${#reports[@]}) in $1:"
  for report in "${reports[@]}"; do
    echo "----- $report"
    cat "$report"
  done
  return 1
}

# run_stage NAME BUILD_DIR CMAKE_SANITIZE OPTIMIZATION TEST_CODE_FLAGS:
# configure, build the target NAME_tests, run the tests of its labels (the ctest
# -L expression CMake writes to <build>/NAME_tests.labels; CMakeLists.txt
# declares the labels), check the reports; prints the duration of the build and
# the tests. -g1 (line tables) is what a sanitizer report needs: full -g made
# the Eigen/Ceres-heavy objects several times larger and their links slow.
# TEST_CODE_FLAGS are DFSM_TEST_CODE_FLAGS (CMakeLists.txt says why the test
# code has its own).
run_stage() {
  local name="$1" build="$2" sanitize="$3" opt="$4" test_code="$5" target="$1_tests"
  local start="$SECONDS"
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$opt -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="$opt -DNDEBUG" \
    -DDFSM_SANITIZE="$sanitize" -DDFSM_WERROR=ON -DDFSM_BUILD_TESTS=ON -DDFSM_BUILD_BENCH=OFF \
    -DDFSM_TEST_CODE_FLAGS="$test_code" -DDFSM_UNITY_BUILD=ON
  cmake --build "$build" --parallel "$jobs" --target "$target"
  local built="$SECONDS"
  local reports="$build/sanitizer-reports"
  rm -rf "$reports"
  mkdir -p "$reports"
  local status=0
  local labels
  labels="$(cat "$build/$target.labels")"
  echo "== $name: ctest -L '$labels'"
  (cd "$build" && ctest --output-on-failure --timeout 900 -j "$jobs" -L "$labels") || status=$?
  check_reports "$reports" || status=1
  echo "== $name: build $((built - start)) s, tests $((SECONDS - built)) s"
  return "$status"
}

asan_build="${DFSM_ASAN_BUILD_DIR:-$root/build-asan}"
tsan_build="${DFSM_TSAN_BUILD_DIR:-$root/build-tsan}"
status=0
# The kill -9 test's rounds walk the same paths, which is what TSan checks; the
# release stage's 24 rounds are what tries many kill points. 4 instead of 24
# saves ~6 min under TSan (one round ~18 s there).
export DFSM_KILL_ROUNDS="${DFSM_KILL_ROUNDS:-4}"
for stage in "${stages[@]}"; do
  case "$stage" in
    asan)
      echo "== address + undefined-behaviour sanitizers: the unit tests (labels unit, hostile)"
      ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:log_path=$asan_build/sanitizer-reports/asan" \
        UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:log_path=$asan_build/sanitizer-reports/ubsan" \
        run_stage asan "$asan_build" address,undefined "-O1 -g1" "-fno-sanitize=undefined" || status=1
      ;;
    tsan)
      echo "== thread sanitizer: capture, service and API unit tests, dfsmd end to end"
      TSAN_OPTIONS="suppressions=$root/scripts/tsan.supp:second_deadlock_stack=1:log_path=$tsan_build/sanitizer-reports/tsan" \
        run_stage tsan "$tsan_build" thread "-O2 -g1" "-O0" || status=1
      ;;
    *)
      echo "unknown sanitizer stage '$stage' (asan or tsan)" >&2
      exit 2
      ;;
  esac
done
exit "$status"
