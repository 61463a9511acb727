# Sourced by vm_run.sh and install_test.sh: the Debian kernel both VMs boot,
# linux-image-amd64's dependency resolved now (not when the script was written),
# downloaded once into the cache and unpacked with its module index.
# Needs: $cache, and a skip function (exit 77 naming the reason).
# Sets: package, kver, kroot, vmlinuz, moddir.
fetch_vm_kernel() {
  mkdir -p "$cache"
  package="$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/ {print $2; exit}')"
  [ -n "$package" ] || skip "apt-cache cannot resolve linux-image-amd64"
  kver="${package#linux-image-}"
  kroot="$cache/$package"
  if [ ! -f "$kroot/.ready" ]; then
    echo "$(basename "$0"): fetching $package" >&2
    rm -rf "$kroot" "$cache/download"
    mkdir -p "$cache/download"
    (cd "$cache/download" && apt-get download "$package" >/dev/null 2>&1) ||
      skip "cannot download $package (offline?)"
    dpkg -x "$cache"/download/*.deb "$kroot"
    depmod -b "$kroot" "$kver"
    rm -rf "$cache/download"
    touch "$kroot/.ready"
  fi
  vmlinuz="$kroot/boot/vmlinuz-$kver"
  moddir="$kroot/lib/modules/$kver"
}
