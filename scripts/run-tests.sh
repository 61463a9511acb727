#!/usr/bin/env bash
# The test command: installs what is missing, builds with warnings as errors and
# runs every test that belongs in the default run, then rebuilds with
# AddressSanitizer + UndefinedBehaviorSanitizer and runs the unit tests again.
#
#   DFSM_TEST_LONG=1   also run the suites labelled "long"
#   DFSM_SANITIZE=0    skip the sanitizer build
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/install-deps.sh"
jobs="$(nproc)"

exclude=()
[ "${DFSM_TEST_LONG:-0}" = 1 ] || exclude=(-LE long)

echo "== release build, -Werror"
BUILD_DIR="$root/build" "$root/scripts/build.sh" \
  -DDFSM_WERROR=ON -DDFSM_BUILD_TESTS=ON -DDFSM_BUILD_BENCH=ON
(cd "$root/build" && ctest --output-on-failure --timeout 900 -j "$jobs" "${exclude[@]}")

if [ "${DFSM_SANITIZE:-1}" != 0 ]; then
  echo "== address + undefined-behaviour sanitizers"
  BUILD_DIR="$root/build-asan" "$root/scripts/build.sh" \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDFSM_SANITIZE=address,undefined \
    -DDFSM_WERROR=ON -DDFSM_BUILD_TESTS=ON -DDFSM_BUILD_BENCH=OFF
  (cd "$root/build-asan" &&
    ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
      ctest --output-on-failure --timeout 900 -j "$jobs" -L unit)
fi
