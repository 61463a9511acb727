#!/usr/bin/env bash
# Builds dfsm's Debian packages, dfsmd and dfsm (issue 14; debian/, docs/packaging.md):
#
#   scripts/build-deb.sh          # amd64, native
#   scripts/build-deb.sh arm64    # arm64, cross-built against an arm64 sysroot
#
# The build runs in a copy of the tree (never in build/ or the checkout), with
# DEB_BUILD_OPTIONS="nocheck parallel=2" unless DEB_BUILD_OPTIONS is set, and
# nice -n 19. The .deb, .buildinfo and .changes files go to out/deb/<arch>/ and
# lintian checks them (any error fails the script).
#
#   DEB_OUT         output directory (default out/deb/<arch>)
#   DEB_WORK        work directory for the copy (default /tmp/dfsm-deb-<arch>)
#   DEB_CHROOT      arm64 only: the cross-build chroot (default
#                   /var/cache/dfsm/cross-arm64): Debian 12 amd64 with arm64 as a
#                   foreign architecture, crossbuild-essential-arm64 and the arm64
#                   build dependencies of debian/control; made with mmdebstrap
#                   when absent (76 s, 0.7 GB measured; 3.8 GB once apt-get
#                   build-dep has added the arm64 libraries), refreshed by
#                   apt-get build-dep on every run.
#   DEB_MIRROR      Debian mirror of that chroot (default http://deb.debian.org/debian)
#
# arm64 with the unit tests (ctest -L unit under qemu-user, package
# qemu-user-static; docs/packaging.md):
#   DEB_BUILD_OPTIONS="parallel=2" scripts/build-deb.sh arm64
# The arm64 test binaries run through binfmt_misc when the host has an enabled
# qemu-aarch64 entry with the F flag (binfmt-support; works inside the chroot);
# otherwise the script copies /usr/bin/qemu-aarch64-static into the chroot and
# debian/rules hands it to CMake as CMAKE_CROSSCOMPILING_EMULATOR.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
arch="${1:-amd64}"
case "$arch" in
  amd64 | arm64) ;;
  *) echo "usage: $0 [amd64|arm64]" >&2; exit 2 ;;
esac
out="${DEB_OUT:-$root/out/deb/$arch}"
work="${DEB_WORK:-/tmp/dfsm-deb-$arch}"
export DEB_BUILD_OPTIONS="${DEB_BUILD_OPTIONS:-nocheck parallel=2}"
# nocheck: also the nocheck build profile, so that the test-only build
# dependencies (libgtest-dev, libgmock-dev, opencv-doc: <!nocheck> in
# debian/control) are neither checked nor installed.
if [ -z "${DEB_BUILD_PROFILES:-}" ] && tr ' ' '\n' <<<"$DEB_BUILD_OPTIONS" | grep -qx nocheck; then
  export DEB_BUILD_PROFILES=nocheck
fi
start=$SECONDS

# The packaging tools and the build dependencies are installed as the other
# scripts install theirs: what is missing, as root (otherwise named).
ensure_packages() {
  local missing=() package
  for package in "$@"; do
    dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" ||
      missing+=("$package")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" -ne 0 ]; then
    echo "build-deb: missing ${missing[*]}: run as root, or apt-get install them" >&2
    exit 1
  fi
  echo "build-deb: installing ${missing[*]}"
  apt_updated
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
}
apt_updated() {  # once per run: a fresh container has no package lists
  [ -n "${apt_lists_fresh:-}" ] && return 0
  apt-get update -qq
  apt_lists_fresh=1
}
ensure_packages lintian  # both architectures' packages are checked with it

# A copy of the tree: the source package's name as its directory, so that the
# packages land beside it in $work.
# (tar rather than rsync: nothing beyond the base system and the build
# dependencies is needed.)
rm -rf "$work/dfsm"
mkdir -p "$work/dfsm" "$out"
tar -C "$root" --anchored --exclude=./.git --exclude='./build*' --exclude=./out \
  --exclude=./.cache --exclude=./debian/build --exclude=./debian/.debhelper \
  --exclude=./debian/tmp --exclude=./debian/dfsm --exclude=./debian/dfsmd -cf - . |
  tar -C "$work/dfsm" -xf -
rm -f "$work"/*.deb "$work"/*.ddeb "$work"/*.buildinfo "$work"/*.changes

if [ "$arch" = amd64 ]; then
  [ "$(dpkg --print-architecture)" = amd64 ] || { echo "build-deb: amd64 builds natively on amd64 only" >&2; exit 1; }
  ensure_packages debhelper dpkg-dev
  if ! (cd "$work/dfsm" && dpkg-checkbuilddeps 2>/dev/null); then
    [ "$(id -u)" -eq 0 ] || {
      (cd "$work/dfsm" && dpkg-checkbuilddeps) || true
      echo "build-deb: run as root to install the build dependencies above" >&2
      exit 1
    }
    echo "build-deb: installing the build dependencies of debian/control"
    apt_updated
    (cd "$work/dfsm" && DEBIAN_FRONTEND=noninteractive apt-get build-dep -y -qq \
      --no-install-recommends ./)
  fi
  (cd "$work/dfsm" && nice -n 19 dpkg-buildpackage -b -us -uc)
else
  chroot_dir="${DEB_CHROOT:-/var/cache/dfsm/cross-arm64}"
  mirror="${DEB_MIRROR:-http://deb.debian.org/debian}"
  [ "$(id -u)" -eq 0 ] || { echo "build-deb: arm64 needs root (chroot, mounts)" >&2; exit 1; }
  if [ ! -x "$chroot_dir/usr/bin/dpkg-buildpackage" ]; then
    # The arm64 libraries are installed as the chroot's foreign architecture, so
    # that dpkg-shlibdeps finds their symbols files; libopencv-dev:arm64 could
    # not join the host's libopencv-dev:amd64 (not Multi-Arch co-installable).
    ensure_packages mmdebstrap
    rm -rf "$chroot_dir.tmp"
    mkdir -p "$(dirname "$chroot_dir")"
    nice -n 19 mmdebstrap --architectures=amd64,arm64 --variant=apt \
      --include=crossbuild-essential-arm64,debhelper,dpkg-dev,cmake,ninja-build,pkgconf \
      --dpkgopt='path-exclude=/usr/share/doc/*' --dpkgopt='path-include=/usr/share/doc/*/copyright' \
      --dpkgopt='path-exclude=/usr/share/man/*' \
      bookworm "$chroot_dir.tmp" "deb $mirror bookworm main" "deb $mirror bookworm-updates main" \
      "deb ${mirror%/debian}/debian-security bookworm-security main"
    mv "$chroot_dir.tmp" "$chroot_dir"
  fi
  # /proc, /sys and /dev for the build; unmounted however the build ends.
  mounts=()
  cleanup() {
    local i
    for ((i = ${#mounts[@]} - 1; i >= 0; i--)); do umount -l "${mounts[i]}" || true; done
  }
  trap cleanup EXIT
  for fs in proc sys dev; do
    mount --rbind "/$fs" "$chroot_dir/$fs"
    mount --make-rslave "$chroot_dir/$fs"
    mounts+=("$chroot_dir/$fs")
  done
  cp /etc/resolv.conf "$chroot_dir/etc/resolv.conf"
  # The unit tests (no nocheck): arm64 binaries executed on this amd64 machine.
  emulator=""
  checking=0
  tr ' ' '\n' <<<"$DEB_BUILD_OPTIONS" | grep -qx nocheck || checking=1
  if [ "$checking" = 1 ]; then
    # opencv-doc's photographs texture synth's scenes in the unit tests; the
    # chroot's dpkg would drop them with the rest of /usr/share/doc.
    printf '%s\n' '# scripts/build-deb.sh: the unit tests read the photographs of opencv-doc' \
      'path-include=/usr/share/doc/opencv-doc/*' >"$chroot_dir/etc/dpkg/dpkg.cfg.d/dfsm-opencv-doc"
    entry=/proc/sys/fs/binfmt_misc/qemu-aarch64
    if grep -qx enabled "$entry" 2>/dev/null && grep -q '^flags:.*F' "$entry"; then
      echo "build-deb: arm64 tests run under qemu-user through binfmt_misc ($(sed -n 's/^interpreter //p' "$entry"))"
    elif [ -x /usr/bin/qemu-aarch64-static ]; then
      cp /usr/bin/qemu-aarch64-static "$chroot_dir/usr/bin/qemu-aarch64-static"
      emulator=/usr/bin/qemu-aarch64-static
      echo "build-deb: no enabled binfmt_misc entry qemu-aarch64 with the F flag;" \
        "arm64 tests run through CMAKE_CROSSCOMPILING_EMULATOR=$emulator"
    else
      echo "build-deb: the arm64 unit tests need qemu-user (apt-get install qemu-user-static)," \
        "or build with DEB_BUILD_OPTIONS=nocheck" >&2
      exit 1
    fi
  fi
  rm -rf "$chroot_dir/build"
  mkdir -p "$chroot_dir/build"
  cp -a "$work/dfsm" "$chroot_dir/build/dfsm"
  export DEBIAN_FRONTEND=noninteractive
  chroot "$chroot_dir" apt-get update -qq
  profiles=()
  [ -z "${DEB_BUILD_PROFILES:-}" ] || profiles=(-P "$(printf '%s' "$DEB_BUILD_PROFILES" | tr ' ' ',')")
  chroot "$chroot_dir" apt-get build-dep -y -qq --no-install-recommends -a arm64 "${profiles[@]}" /build/dfsm
  if [ "$checking" = 1 ] && [ -z "$(find "$chroot_dir/usr/share/doc/opencv-doc/examples/data" -type f -print -quit 2>/dev/null)" ]; then
    chroot "$chroot_dir" apt-get install -y -qq --reinstall opencv-doc  # installed before the path-include
  fi
  chroot "$chroot_dir" env DFSM_CROSS_EMULATOR="$emulator" \
    sh -c "cd /build/dfsm && nice -n 19 dpkg-buildpackage -a arm64 -b -us -uc"
  cp "$chroot_dir"/build/*.deb "$chroot_dir"/build/*.buildinfo "$chroot_dir"/build/*.changes "$work/"
  cleanup
  mounts=()
fi

rm -f "$out"/*.deb "$out"/*.ddeb "$out"/*.buildinfo "$out"/*.changes
cp "$work"/*.deb "$work"/*.buildinfo "$work"/*.changes "$out/"
echo "build-deb: built in $((SECONDS - start)) s:"
ls -l "$out"

# lintian: errors fail; warnings are fixed or explained in debian/*.lintian-overrides.
changes="$(ls "$out"/*.changes)"
lintian --fail-on error --display-info "$changes"
echo "build-deb: lintian reports no errors for $changes"
