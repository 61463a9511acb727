#!/usr/bin/env bash
# Builds the vimc module for kernel KVER out of tree (Debian's kernel does not
# ship it) from linux-source-<series> (apt-get download) against the installed
# linux-headers-KVER, caches it in CACHE and prints its path. Exit 77 when the
# headers or the source package cannot be had.
#
#   build_vimc.sh KVER CACHE
set -euo pipefail
kver="$1"
cache="$2"
ko="$cache/vimc-$kver/vimc.ko"
if [ -f "$ko" ]; then
  echo "$ko"
  exit 0
fi
headers="/usr/src/linux-headers-$kver"
if [ ! -d "$headers" ]; then
  echo "build_vimc: $headers missing (apt-get install linux-headers-$kver)" >&2
  exit 77
fi
series="$(echo "$kver" | cut -d. -f1,2)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
if ! (cd "$work" && apt-get download "linux-source-$series" >/dev/null 2>&1); then
  echo "build_vimc: cannot download linux-source-$series" >&2
  exit 77
fi
dpkg-deb --fsys-tarfile "$work"/linux-source-*.deb |
  tar -xO "./usr/src/linux-source-$series.tar.xz" | xz -dc |
  tar -x -C "$work" "linux-source-$series/drivers/media/test-drivers/vimc"
src="$work/linux-source-$series/drivers/media/test-drivers/vimc"
if ! make -C "$headers" M="$src" CONFIG_VIDEO_VIMC=m modules >"$work/build.log" 2>&1; then
  tail -20 "$work/build.log" >&2
  exit 1
fi
mkdir -p "$(dirname "$ko")"
cp "$src/vimc.ko" "$ko"
echo "$ko"
