#!/usr/bin/env bash
# The test command: installs what is missing, builds with warnings as errors and
# runs every test that belongs in the default run. Longer suites carry the ctest
# label "long" and run with DFSM_TEST_LONG=1.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/install-deps.sh"
export BUILD_DIR="${BUILD_DIR:-$root/build}"
"$root/scripts/build.sh" -DDFSM_WERROR=ON -DDFSM_BUILD_TESTS=ON -DDFSM_BUILD_BENCH=ON
cd "$BUILD_DIR"
exclude=()
[ "${DFSM_TEST_LONG:-0}" = 1 ] || exclude=(-LE long)
ctest --output-on-failure --timeout 900 -j "$(nproc)" "${exclude[@]}"
