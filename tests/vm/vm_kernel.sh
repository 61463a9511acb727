# Sourced by vm_run.sh and install_test.sh: the Debian kernel the VMs boot,
# linux-image-<arch>'s dependency resolved now (not when the script was written),
# downloaded once into the cache and unpacked with its module index.
#
#   fetch_vm_kernel [ARCH [SOURCES...]]
#
# ARCH: amd64 (default: the host's apt resolves and downloads it) or arm64 (a
# private apt state in $cache/apt-arm64 with arm64 as its only architecture,
# reading SOURCES, apt sources files of Debian 12; default the host's
# /etc/apt/sources.list.d/debian.sources; the host's own apt is not touched).
# Needs: $cache, and a skip function (exit 77 naming the reason).
# Sets: package, kver, kroot, vmlinuz, moddir.
fetch_vm_kernel() {
  local arch="${1:-amd64}"
  [ $# -gt 0 ] && shift
  mkdir -p "$cache"
  if [ "$arch" = amd64 ]; then
    package="$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/ {print $2; exit}')"
  else
    vm_foreign_apt_init "$arch" "$@"
    package="$(vm_foreign_apt apt-cache depends "linux-image-$arch" 2>/dev/null |
      awk '/Depends: linux-image-[0-9]/ {print $2; exit}')"
  fi
  [ -n "$package" ] || skip "apt-cache cannot resolve linux-image-$arch"
  kver="${package#linux-image-}"
  kroot="$cache/$package"
  if [ ! -f "$kroot/.ready" ]; then
    echo "$(basename "$0"): fetching $package" >&2
    rm -rf "$kroot"
    vm_fetch_package "$arch" "$package" "$kroot"
    depmod -b "$kroot" "$kver"
    touch "$kroot/.ready"
  fi
  vmlinuz="$kroot/boot/vmlinuz-$kver"
  moddir="$kroot/lib/modules/$kver"
}

# vm_foreign_apt_init ARCH [SOURCES...]: the private apt state of ARCH in
# $cache/apt-ARCH, its package lists refreshed once a day.
vm_foreign_apt_init() {
  local arch="$1" f
  shift
  vm_apt_dir="$cache/apt-$arch"
  mkdir -p "$vm_apt_dir/lists/partial" "$vm_apt_dir/archives/partial" "$vm_apt_dir/parts"
  touch "$vm_apt_dir/status"
  rm -f "$vm_apt_dir"/parts/*
  [ $# -gt 0 ] || set -- /etc/apt/sources.list.d/debian.sources
  for f in "$@"; do
    [ -f "$f" ] || skip "no apt sources file $f"
    case "$f" in
      *.sources) cp "$f" "$vm_apt_dir/parts/" ;;
      *) cp "$f" "$vm_apt_dir/parts/$(basename "$f" .list).list" ;;
    esac
  done
  vm_apt_opts=(-o "Dir::State=$vm_apt_dir" -o "Dir::State::Lists=$vm_apt_dir/lists"
    -o "Dir::State::status=$vm_apt_dir/status" -o "Dir::Cache=$vm_apt_dir"
    -o "Dir::Cache::archives=$vm_apt_dir/archives" -o Dir::Etc::SourceList=/dev/null
    -o "Dir::Etc::SourceParts=$vm_apt_dir/parts" -o "APT::Architecture=$arch"
    -o "APT::Architectures::=$arch" -o Acquire::Languages=none)
  if [ -z "$(find "$vm_apt_dir/lists" -maxdepth 1 -name '*Packages*' -mmin -1440 2>/dev/null)" ]; then
    apt-get "${vm_apt_opts[@]}" -qq update >/dev/null 2>&1 ||
      skip "cannot update the $arch package lists (offline?)"
  fi
}

# vm_foreign_apt COMMAND ARGS...: apt-get/apt-cache with that private state.
vm_foreign_apt() {
  local command="$1"
  shift
  "$command" "${vm_apt_opts[@]}" "$@"
}

# vm_fetch_package ARCH PACKAGE DIR: downloads PACKAGE of ARCH and unpacks it
# (dpkg -x) into DIR.
vm_fetch_package() {
  local arch="$1" pkg="$2" dest="$3" download="$cache/download"
  rm -rf "$download"
  mkdir -p "$download"
  if [ "$arch" = amd64 ]; then
    (cd "$download" && apt-get download "$pkg" >/dev/null 2>&1) || skip "cannot download $pkg (offline?)"
  else
    (cd "$download" && vm_foreign_apt apt-get download "$pkg" >/dev/null 2>&1) ||
      skip "cannot download $pkg for $arch (offline?)"
  fi
  dpkg -x "$download"/*.deb "$dest"
  rm -rf "$download"
}
