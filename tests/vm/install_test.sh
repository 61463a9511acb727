#!/usr/bin/env bash
# Install test on a booted Debian 12 system (issue 14, item 3; docs/packaging.md,
# "Install test on a booted image"). As root:
#
#   tests/vm/install_test.sh [OUT_DIR]        # default OUT_DIR: /tmp/dfsm-install-test
#   DFSM_INSTALL_ARCH=arm64 tests/vm/install_test.sh [OUT_DIR]   # the arm64 image
#
# 1. builds a minimal Debian 12 image with mmdebstrap (minbase + systemd-sysv,
#    udev, curl, kmod, v4l-utils) from the Debian sources apt uses on this
#    machine, installs the freshly built dfsmd .deb into it with
#    `apt-get install ./dfsmd_*.deb` (which pulls in its libraries), points
#    /etc/dfsmd/dfsmd.toml at vivid's /dev/video0 (a small capture size for the
#    emulated CPU) and has vivid loaded at boot (modules-load.d);
# 2. boots it under qemu-system-x86_64 (TCG, no KVM, 1 vCPU) with the Debian
#    kernel the VM harness uses (vm_run.sh: linux-image-amd64's dependency,
#    cached in DFSM_VM_CACHE), its modules copied into the image, and a busybox
#    initramfs that mounts the ext4 image and hands over to systemd;
#    with DFSM_INSTALL_ARCH=arm64: an arm64 image (mmdebstrap runs its
#    maintainer scripts under qemu-user through binfmt_misc), the arm64 .deb,
#    linux-image-arm64's dependency and busybox-static:arm64 (downloaded with a
#    private arm64 apt state, vm_kernel.sh), booted under qemu-system-aarch64
#    -M virt -cpu max (TCG);
# 3. a oneshot unit inside (install_check.sh) checks, after dfsmd:
#    `systemctl is-active dfsmd`; POST /api/v1/captures answers 202 and the job
#    succeeds with a depth map; `systemctl restart dfsmd` keeps the finished job;
#    `apt-get remove dfsmd` stops the service and keeps /var/lib/dfsmd; it prints
#    its results on the serial console and powers the VM off.
# Every stage prints its duration. Exit status: 0 pass, 1 fail, 77 skipped
# (ctest) when root, mmdebstrap, qemu, a static busybox, the .deb or the kernel
# package are missing (arm64: also qemu-user's binfmt_misc entry), 124 when the
# VM ran past DFSM_VM_TIMEOUT.
#
#   DFSM_INSTALL_ARCH     amd64 (default) or arm64
#   DFSM_INSTALL_DEB      the dfsmd .deb (default: the newest out/deb/<arch>/dfsmd_*_<arch>.deb,
#                         which scripts/build-deb.sh [arm64] writes)
#   DFSM_INSTALL_SOURCES  an apt sources file (.sources or .list) for the image
#                         (default: the host's files naming bookworm, bookworm-updates
#                         or bookworm-security)
#   DFSM_VM_CACHE         kernel and package cache (default ~/.cache/dfsm-vm, as vm_run.sh)
#   DFSM_VM_TIMEOUT       seconds the booted VM may run (default 1500)
#   DFSM_VM_MEMORY        MiB (default 2048), DFSM_VM_CPUS (default 1)
#   DFSM_INSTALL_KEEP=1   keep the image and the root tree in OUT_DIR
#   DFSM_TEST_INSTALL=1   needed under ctest (label install-image), which sets
#                         DFSM_INSTALL_CTEST=1: without it the test skips
#   DFSM_TEST_INSTALL_ARM64=1  the same for the arm64 image (label install-image-arm64)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="$(realpath -m "${1:-/tmp/dfsm-install-test}")"
cache="${DFSM_VM_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/dfsm-vm}"
timeout_s="${DFSM_VM_TIMEOUT:-1500}"
arch="${DFSM_INSTALL_ARCH:-amd64}"
case "$arch" in
  amd64 | arm64) ;;
  *) echo "install_test: DFSM_INSTALL_ARCH must be amd64 or arm64, not $arch" >&2; exit 2 ;;
esac

skip() {
  echo "install_test: SKIP: $*" >&2
  exit 77
}
log() { echo "install_test: $*"; }
t0=$SECONDS
stage_start=$SECONDS
durations=()
stage_end() {  # NAME
  local d=$((SECONDS - stage_start))
  durations+=("$1: ${d} s")
  echo "== duration of $1: ${d} s"
  stage_start=$SECONDS
}

# --- what the test needs
if [ "${DFSM_INSTALL_CTEST:-0}" = 1 ]; then
  if [ "$arch" = amd64 ] && [ "${DFSM_TEST_INSTALL:-0}" != 1 ]; then
    skip "the install test builds and boots a Debian image (~3 min); set DFSM_TEST_INSTALL=1 to run it" \
      "(ctest -L install-image)"
  fi
  if [ "$arch" = arm64 ] && [ "${DFSM_TEST_INSTALL_ARM64:-0}" != 1 ]; then
    skip "the arm64 install test builds an arm64 image under qemu-user and boots it under" \
      "qemu-system-aarch64 (TCG, ~6 min); set DFSM_TEST_INSTALL_ARM64=1 to run it (ctest -L install-image-arm64)"
  fi
fi
[ "$(id -u)" -eq 0 ] || skip "needs root (mmdebstrap in root mode, chroot, mke2fs of the image)"
[ "$(dpkg --print-architecture 2>/dev/null)" = amd64 ] ||
  skip "written for an amd64 host (the amd64 image natively, the arm64 one under qemu)"
command -v mmdebstrap >/dev/null || skip "mmdebstrap missing (apt-get install mmdebstrap)"
if [ "$arch" = amd64 ]; then
  qemu_system=qemu-system-x86_64
  command -v $qemu_system >/dev/null || skip "$qemu_system missing (apt-get install qemu-system-x86)"
else
  qemu_system=qemu-system-aarch64
  command -v $qemu_system >/dev/null || skip "$qemu_system missing (apt-get install qemu-system-arm)"
  command -v arch-test >/dev/null || skip "arch-test missing (apt-get install arch-test: mmdebstrap needs it for arm64)"
  # mmdebstrap runs the arm64 image's maintainer scripts (and install_image_setup.sh
  # runs its dfsmd --check-config) under qemu-user, through binfmt_misc.
  grep -qx enabled /proc/sys/fs/binfmt_misc/qemu-aarch64 2>/dev/null ||
    skip "no binfmt_misc entry qemu-aarch64 (apt-get install qemu-user-static binfmt-support;" \
      "mount -t binfmt_misc binfmt_misc /proc/sys/fs/binfmt_misc; update-binfmts --enable qemu-aarch64)"
fi
command -v mke2fs >/dev/null || skip "mke2fs missing (apt-get install e2fsprogs)"
command -v depmod >/dev/null || skip "depmod missing (apt-get install kmod)"
command -v cpio >/dev/null || skip "cpio missing (apt-get install cpio)"
busybox=""
if [ "$arch" = amd64 ]; then
  for candidate in /bin/busybox /usr/bin/busybox; do
    if [ -x "$candidate" ] && ! ldd "$candidate" >/dev/null 2>&1; then busybox="$candidate"; fi
  done
  [ -n "$busybox" ] || skip "no static busybox (apt-get install busybox-static)"
fi
deb="${DFSM_INSTALL_DEB:-$(ls -t "$root"/out/deb/"$arch"/dfsmd_*_"$arch".deb 2>/dev/null | head -1)}"
[ -n "$deb" ] && [ -f "$deb" ] ||
  skip "no dfsmd .deb: run scripts/build-deb.sh $arch (out/deb/$arch/) or set DFSM_INSTALL_DEB"
deb="$(realpath "$deb")"
if [ -n "${DFSM_INSTALL_SOURCES:-}" ]; then
  sources=("$DFSM_INSTALL_SOURCES")
else
  # The host's Debian 12 sources: the files that name one of bookworm's suites
  # (not third-party ones such as cloud-sdk-bookworm).
  sources=()
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list /etc/apt/sources.list.d/*.sources; do
    [ -f "$f" ] || continue
    grep -qE '^[^#]*(^|[[:space:]])bookworm(-updates|-security)?([[:space:]]|$)' "$f" && sources+=("$f")
  done
  [ ${#sources[@]} -gt 0 ] || skip "no apt sources naming bookworm on this machine (set DFSM_INSTALL_SOURCES)"
fi
[ "$(dpkg-deb -f "$deb" Architecture)" = "$arch" ] || skip "$deb is not an $arch package"
log "architecture: $arch; package: $deb"
log "apt sources: ${sources[*]}"

# --- the kernel: the one vm_run.sh boots (linux-image-amd64's dependency), same
# cache; for arm64 linux-image-arm64's dependency and busybox-static, from the
# same Debian sources through a private arm64 apt state (vm_kernel.sh)
# shellcheck source=tests/vm/vm_kernel.sh
source "$(dirname "${BASH_SOURCE[0]}")/vm_kernel.sh"
if [ "$arch" = amd64 ]; then
  fetch_vm_kernel
else
  fetch_vm_kernel "$arch" "${sources[@]}"
  bb_package="$(vm_foreign_apt apt-cache show busybox-static 2>/dev/null | awk '/^Version:/ {print $2; exit}')"
  [ -n "$bb_package" ] || skip "apt-cache cannot resolve busybox-static for $arch"
  bb_root="$cache/busybox-static_${bb_package//:/_}_$arch"
  if [ ! -x "$bb_root/bin/busybox" ]; then
    rm -rf "$bb_root"
    vm_fetch_package "$arch" busybox-static "$bb_root"
  fi
  busybox="$bb_root/bin/busybox"
fi

rm -rf "$out"
mkdir -p "$out"
work="$out/work"
rootfs="$work/rootfs"
image="$out/image.ext4"
mkdir -p "$work"
cleanup() {
  if [ "${DFSM_INSTALL_KEEP:-0}" != 1 ]; then rm -rf "$work" "$image"; fi
}
trap cleanup EXIT

# Modules: in load order, with their dependencies (modprobe --show-depends).
modules_of() {  # MODULE...: paths relative to $moddir
  local m
  for m in "$@"; do
    modprobe -d "$kroot" -S "$kver" --show-depends "$m" | awk '$1 == "insmod" {print $2}'
  done | sed "s|^$moddir/||" | awk '!seen[$0]++'
}
boot_modules="$(modules_of virtio_pci virtio_blk crc32c_generic ext4)"
image_modules="$(modules_of virtio_pci virtio_blk crc32c_generic ext4 vivid virtio_rng)"

# --- stage 1: the image
log "building the image with mmdebstrap"
pkg_cache="$cache/install-debs"
[ "$arch" = amd64 ] || pkg_cache="$cache/install-debs-$arch"
mkdir -p "$pkg_cache"
printf '%s\n' "$image_modules" >"$work/image-modules"
# The downloaded packages are kept in $pkg_cache between runs (sync-in before,
# sync-out after), so a rerun downloads only what changed. The .deb goes in
# with its Recommends, as `apt install ./dfsmd_*.deb` on a board (mmdebstrap's
# apt configuration leaves them out).
nice -n 10 mmdebstrap --variant=minbase --mode=root --architectures="$arch" \
  --include=systemd-sysv,udev,kmod,curl,v4l-utils \
  --dpkgopt='path-exclude=/usr/share/man/*' --dpkgopt='path-exclude=/usr/share/locale/*' \
  --dpkgopt='path-exclude=/usr/share/doc/*' --dpkgopt='path-include=/usr/share/doc/*/copyright' \
  --dpkgopt='path-include=/usr/share/doc/dfsmd/*' \
  --skip=download/empty --skip=essential/unlink \
  --setup-hook="mkdir -p \"\$1/var/cache/apt/archives/\"" \
  --setup-hook="sync-in $pkg_cache /var/cache/apt/archives/" \
  --customize-hook="copy-in $deb /root/" \
  --customize-hook='chroot "$1" env DEBIAN_FRONTEND=noninteractive apt-get install -y -o APT::Install-Recommends=true /root/'"$(basename "$deb")" \
  --customize-hook="sync-out /var/cache/apt/archives $pkg_cache" \
  --customize-hook='rm -f "$1"/var/cache/apt/archives/*.deb' \
  --customize-hook="copy-in $here/install_check.sh /usr/local/sbin/" \
  --customize-hook="'$here/install_image_setup.sh' \"\$1\" '$moddir' '$work/image-modules'" \
  bookworm "$rootfs" "${sources[@]}"
stage_end "image build (mmdebstrap + apt install of the .deb)"

# The root file system: ext4 of the tree, with room for jobs.
size_mb=$(( $(du -sm "$rootfs" | cut -f1) + 768 ))
mke2fs -q -t ext4 -L dfsm-root -d "$rootfs" "$image" "${size_mb}M"
log "image: $image, ${size_mb} MiB ($(du -sm "$rootfs" | cut -f1) MiB of files)"
if [ "${DFSM_INSTALL_KEEP:-0}" != 1 ]; then rm -rf "$rootfs"; fi

# The initramfs: busybox, virtio + ext4 modules, an /init that mounts the image
# and hands over to systemd.
staging="$work/initramfs"
mkdir -p "$staging"/{bin,proc,sys,dev,newroot}
cp "$busybox" "$staging/bin/busybox"
printf '%s\n' "$boot_modules" >"$staging/boot-modules"
while read -r rel; do
  mkdir -p "$staging/lib/modules/$kver/$(dirname "$rel")"
  cp "$moddir/$rel" "$staging/lib/modules/$kver/$rel"
done <"$staging/boot-modules"
cat >"$staging/init" <<INIT
#!/bin/busybox sh
/bin/busybox --install -s /bin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
for m in \$(cat /boot-modules); do insmod /lib/modules/$kver/\$m || echo "initramfs: insmod \$m failed"; done
for _ in \$(seq 100); do [ -b /dev/vda ] && break; sleep 0.1; done
mount -t ext4 -o rw /dev/vda /newroot || { echo "initramfs: cannot mount /dev/vda"; poweroff -f; }
echo "initramfs: root mounted after \$(cut -d' ' -f1 /proc/uptime) s"
umount /proc /sys
mount --move /dev /newroot/dev
exec switch_root /newroot /sbin/init
INIT
chmod +x "$staging/init"
(cd "$staging" && find . | cpio -o -H newc 2>/dev/null | gzip -1) >"$work/initramfs.cpio.gz"
stage_end "image file system and initramfs"

# --- stage 2: boot and run the checks
if [ "$arch" = amd64 ]; then
  machine=(-cpu max)
  console=ttyS0
else
  # virt: PCI virtio devices, the PL011 UART ttyAMA0. pauth-impdef: QEMU's
  # own pointer-authentication hash instead of the architected QARMA, which
  # QEMU's documentation names costly under TCG (the kernel and Debian's
  # arm64 userland sign return addresses).
  machine=(-M virt -cpu "max,pauth-impdef=on")
  console=ttyAMA0
fi
log "booting $qemu_system (TCG, ${DFSM_VM_CPUS:-1} vCPU, ${DFSM_VM_MEMORY:-2048} MiB); serial console in $out/serial.log"
set +e
timeout "$timeout_s" nice -n 5 "$qemu_system" -nodefaults -no-user-config -nographic -no-reboot \
  "${machine[@]}" -accel tcg,thread=multi -smp "${DFSM_VM_CPUS:-1}" -m "${DFSM_VM_MEMORY:-2048}" \
  -kernel "$vmlinuz" -initrd "$work/initramfs.cpio.gz" \
  -append "console=$console rdinit=/init panic=-1 quiet systemd.show_status=1 net.ifnames=0" \
  -drive file="$image",format=raw,if=virtio,cache=unsafe \
  -device virtio-rng-pci \
  -serial stdio -monitor none >"$out/serial.log" 2>&1
qemu_status=$?
set -e
stage_end "boot and checks in the VM (qemu wall time)"
if [ "$qemu_status" = 124 ]; then
  log "the VM ran past ${timeout_s} s; end of the serial log:"
  tail -40 "$out/serial.log"
  exit 124
fi

# --- stage 3: the verdict, from the serial console
tr -d '\r' <"$out/serial.log" | grep -a 'install-check' | sed 's/^.*\(install-check\)/\1/' >"$out/checks.log" || true
tr -d '\r' <"$out/serial.log" | grep -ao 'initramfs: root mounted.*' || true
cat "$out/checks.log"
echo "== durations (host)"
printf '  %s\n' "${durations[@]}"
echo "  total: $((SECONDS - t0)) s"
if grep -q '^install-check: RESULT PASS' "$out/checks.log"; then
  log "PASS"
  exit 0
fi
log "FAIL (qemu exit $qemu_status); end of the serial log:"
tail -60 "$out/serial.log"
exit 1
