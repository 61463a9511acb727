#!/usr/bin/env bash
# The `vm` ctest entry: boots the VM once (vm_run.sh), runs vivid_scenarios.sh
# inside, then checks the reports with vm_report_test. Exit 77 (ctest: skipped)
# when no VM can be started here.
#
#   run_vivid_suite.sh DFSM_CAPTURE VM_REPORT_TEST OUT_DIR
set -euo pipefail
if [ "${DFSM_TEST_VM:-0}" != 1 ]; then
  echo "run_vivid_suite: SKIP: the VM tests boot a kernel under qemu (~3 min); set DFSM_TEST_VM=1" \
    "to run them (scripts/run-tests.sh does)" >&2
  exit 77
fi
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
capture="$(realpath "$1")"
checker="$(realpath "$2")"
out="$(realpath -m "$3")"
# The VM mounts a tmpfs of its own over /tmp (the host root it sees is
# read-only), so a build tree under the host's /tmp is invisible inside it.
for path in "$here" "$capture" "$out"; do
  case "$path" in /tmp/*)
    echo "run_vivid_suite: SKIP: $path lies under /tmp, which the VM cannot see (it mounts a" \
      "tmpfs of its own there); put the project and its build tree outside /tmp to run the VM" \
      "tests" >&2
    exit 77 ;;
  esac
done
rm -rf "$out"
mkdir -p "$out"
# libcamera's scenario needs vimc, built out of tree for the VM's kernel.
cache="${DFSM_VM_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/dfsm-vm}"
package="$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/ {print $2; exit}')"
vimc=""
if [ -n "$package" ]; then
  vimc="$("$here/build_vimc.sh" "${package#linux-image-}" "$cache")" ||
    echo "run_vivid_suite: no vimc module: the libcamera scenario will be skipped" >&2
fi
status=0
"$here/vm_run.sh" "$here/vivid_scenarios.sh" "$out" "$capture" "$vimc" || status=$?
[ "$status" = 77 ] && exit 77
echo "run_vivid_suite: the VM's script exited $status; its log:"
cat "$out/vm-console.log" 2>/dev/null || true
DFSM_VM_OUT="$out" "$checker"
