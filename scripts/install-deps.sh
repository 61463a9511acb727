#!/usr/bin/env bash
# Installs the Debian 12 packages dfsm needs to build, test and run. Idempotent:
# packages already present are skipped, so it is cheap on a prepared machine.
#
#   scripts/install-deps.sh             the runtime set and the test set
#   scripts/install-deps.sh --runtime   only what building and running dfsm needs
#                                       (scripts/run-demo.sh): no test tools
#                                       (*-test-deps.txt: browser, fuzz, Slurm, ...)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
runtime_only=0
case "${1:-}" in
  "") ;;
  --runtime) runtime_only=1 ;;
  *) echo "usage: install-deps.sh [--runtime]" >&2; exit 2 ;;
esac

packages=(
  build-essential cmake ninja-build pkg-config git
  libopencv-dev libeigen3-dev libceres-dev libopengv-dev
  nlohmann-json3-dev libcpp-httplib-dev libsystemd-dev
  libexif-dev   # EXIF focal length of uploaded JPEG bursts (core/io/exif_focal)
  libturbojpeg0-dev   # JPEG frames decoded with their scans bounded (core/io/image_decode)
  libpng-dev   # every PNG read and written (core/io/png_encode, png_decode)
  libtiff-dev   # float32 depth maps (core/io/depth_tiff)
  opencv-doc   # real photographs used as textures of the synthetic bursts
)
# Further areas list their own packages, one per line (# comments allowed);
# what only tests need is in *-test-deps.txt.
for list in "$here"/*-deps.txt; do
  [ -f "$list" ] || continue
  case "$list" in *-test-deps.txt) [ "$runtime_only" = 1 ] && continue ;; esac
  while read -r line; do
    line="${line%%#*}"
    line="$(echo "$line" | xargs)"
    [ -n "$line" ] && packages+=("$line")
  done <"$list"
done

missing=()
for package in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" ||
    missing+=("$package")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: must run as root to install packages" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
