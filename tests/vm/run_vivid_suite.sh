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
case "$out" in /tmp/*)
  echo "run_vivid_suite: $out lies under /tmp, which the VM does not see" >&2
  exit 2 ;;
esac
rm -rf "$out"
mkdir -p "$out"
status=0
"$here/vm_run.sh" "$here/vivid_scenarios.sh" "$out" "$capture" || status=$?
[ "$status" = 77 ] && exit 77
echo "run_vivid_suite: the VM's script exited $status; its log:"
cat "$out/vm-console.log" 2>/dev/null || true
DFSM_VM_OUT="$out" "$checker"
