#!/usr/bin/env bash
# Runs an arm64 executable on this amd64 machine under qemu-user, against the
# arm64 libraries of a Debian 12 sysroot (docs/packaging.md, "arm64"):
#
#   scripts/qemu-arm64.sh PROGRAM [ARGS...]
#
#   DFSM_ARM64_SYSROOT  the sysroot (default: $DEB_CHROOT, else /var/cache/dfsm/cross-arm64,
#                       the cross-build chroot scripts/build-deb.sh arm64 makes: its arm64
#                       libraries are the build dependencies' runtime libraries)
#   QEMU_AARCH64        the emulator (default: qemu-aarch64-static, else qemu-aarch64)
#
# No root, chroot or binfmt_misc is needed: qemu-aarch64 -L SYSROOT finds the
# arm64 dynamic loader and libraries under SYSROOT. The sysroot's
# update-alternatives links (libblas.so.3, liblapack.so.3 -> /etc/alternatives
# -> ...) are absolute and would resolve on the host, so the directories they
# point to are put on the guest's LD_LIBRARY_PATH. Exit status: the program's;
# 127 when the emulator or the sysroot is missing.
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: $0 PROGRAM [ARGS...]" >&2; exit 2; }
sysroot="${DFSM_ARM64_SYSROOT:-${DEB_CHROOT:-/var/cache/dfsm/cross-arm64}}"
qemu="${QEMU_AARCH64:-}"
if [ -z "$qemu" ]; then
  qemu="$(command -v qemu-aarch64-static || command -v qemu-aarch64 || true)"
fi
[ -n "$qemu" ] || { echo "qemu-arm64: no qemu-aarch64 (apt-get install qemu-user-static)" >&2; exit 127; }
[ -e "$sysroot/lib/ld-linux-aarch64.so.1" ] || {
  echo "qemu-arm64: $sysroot is not an arm64 sysroot (no lib/ld-linux-aarch64.so.1; scripts/build-deb.sh arm64 makes one)" >&2
  exit 127
}
libdirs=()
for link in "$sysroot"/usr/lib/aarch64-linux-gnu/*; do
  [ -L "$link" ] || continue
  target="$(readlink "$link")"
  case "$target" in
    /etc/alternatives/*)
      resolved="$(readlink "$sysroot$target" || true)"
      [ -n "$resolved" ] && libdirs+=("$(dirname "$resolved")")
      ;;
  esac
done
guest_path="$(printf '%s\n' "${libdirs[@]}" /usr/lib/aarch64-linux-gnu | awk '!seen[$0]++' | paste -sd:)"
exec "$qemu" -L "$sysroot" -E "LD_LIBRARY_PATH=$guest_path" "$@"
