#!/usr/bin/env bash
# Boots the Debian kernel under qemu (no KVM needed) with the host's root
# shared read-only over 9p, runs one script inside (chrooted into the host
# root, so the project's binaries run as built) and collects what it writes.
#
#   vm_run.sh SCRIPT OUT_DIR [ARGS...]
#
# SCRIPT runs as `sh SCRIPT /mnt ARGS...` inside the VM; /mnt is OUT_DIR on the
# host (writable 9p), /tmp and /run are the VM's own tmpfs (so SCRIPT, the
# binaries and ARGS must not live under the host's /tmp). The VM kernel's
# modules load with `$VM_MODPROBE vivid ...` (modprobe -d /run/vm). Exit codes: the script's, 77 when qemu, busybox or the kernel
# package cannot be had (the caller skips), 124 when the VM ran past
# DFSM_VM_TIMEOUT seconds (default 600).
#
# The kernel is the one Debian's linux-image-amd64 depends on, fetched with
# apt-get download and cached in DFSM_VM_CACHE (default ~/.cache/dfsm-vm).
set -euo pipefail

script="$(realpath "$1")"
out="$(realpath -m "$2")"
shift 2
case "$script" in /tmp/*) echo "vm_run: $script lies under /tmp, which the VM does not see" >&2; exit 2 ;; esac
[ -d /mnt ] || { echo "vm_run: the host has no /mnt to mount the output share on" >&2; exit 2; }
cache="${DFSM_VM_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/dfsm-vm}"
timeout_s="${DFSM_VM_TIMEOUT:-600}"

skip() {
  echo "vm_run: SKIP: $*" >&2
  exit 77
}

command -v qemu-system-x86_64 >/dev/null || skip "qemu-system-x86_64 missing (apt-get install qemu-system-x86)"
busybox=""
for candidate in /bin/busybox /usr/bin/busybox; do
  if [ -x "$candidate" ] && ! ldd "$candidate" >/dev/null 2>&1; then busybox="$candidate"; fi
done
[ -n "$busybox" ] || skip "no static busybox (apt-get install busybox-static)"
command -v depmod >/dev/null || skip "depmod missing (apt-get install kmod)"
command -v cpio >/dev/null || skip "cpio missing (apt-get install cpio)"

# --- the kernel: resolve linux-image-amd64's dependency now, not at write time
# shellcheck source=tests/vm/vm_kernel.sh
source "$(dirname "${BASH_SOURCE[0]}")/vm_kernel.sh"
fetch_vm_kernel

# --- the initramfs: busybox, the modules the VM needs, /init
initrd="$cache/initramfs-$kver.cpio.gz"
if [ ! -f "$initrd" ] || [ "$0" -nt "$initrd" ]; then
  staging="$(mktemp -d)"
  trap 'rm -rf "$staging"' EXIT
  mkdir -p "$staging"/{bin,proc,sys,dev,host,lib/modules/"$kver"}
  cp "$busybox" "$staging/bin/busybox"
  # Boot modules (virtio + 9p) in load order, then the video test drivers.
  : >"$staging/boot-modules"
  for module in virtio_pci 9pnet_virtio 9p; do
    modprobe -d "$kroot" -S "$kver" --show-depends "$module" | awk '$1 == "insmod" {print $2}' |
      while read -r path; do
        rel="${path#"$moddir"/}"
        grep -qx "$rel" "$staging/boot-modules" || echo "$rel" >>"$staging/boot-modules"
      done
  done
  for module in vivid vimc; do
    modprobe -d "$kroot" -S "$kver" --show-depends "$module" 2>/dev/null |
      awk '$1 == "insmod" {print $2}' >>"$staging/video-modules" || true
  done
  while read -r rel; do
    mkdir -p "$staging/lib/modules/$kver/$(dirname "$rel")"
    cp "$moddir/$rel" "$staging/lib/modules/$kver/$rel"
  done <"$staging/boot-modules"
  while read -r path; do
    rel="${path#"$moddir"/}"
    mkdir -p "$staging/lib/modules/$kver/$(dirname "$rel")"
    cp "$path" "$staging/lib/modules/$kver/$rel"
  done <"$staging/video-modules"
  cp "$moddir"/modules.builtin* "$moddir"/modules.order "$staging/lib/modules/$kver/"
  depmod -b "$staging" "$kver"
  cat >"$staging/init" <<INIT
#!/bin/busybox sh
/bin/busybox --install -s /bin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
for m in \$(cat /boot-modules); do insmod /lib/modules/$kver/\$m || echo "vm-init: insmod \$m failed"; done
mount -t 9p -o trans=virtio,version=9p2000.L,ro,msize=262144,cache=loose hostroot /host || { echo "vm-init: cannot mount the host root"; poweroff -f; }
mount -t tmpfs tmp /host/tmp
mount -t tmpfs run /host/run
mount -t proc proc /host/proc
mount -t sysfs sys /host/sys
mount -t devtmpfs dev /host/dev
mkdir -p /host/run/vm/lib
mount -o bind /lib /host/run/vm/lib
mount -t 9p -o trans=virtio,version=9p2000.L,msize=262144 out /host/mnt || { echo "vm-init: cannot mount the output share on /mnt"; poweroff -f; }
echo "vm-init: up after \$(cut -d' ' -f1 /proc/uptime) s"
chroot /host /bin/sh -c 'cd /mnt && . ./vm-command' >/host/mnt/vm-console.log 2>&1
echo \$? >/host/mnt/vm-exit-code
sync
umount /host/mnt
echo "vm-init: done after \$(cut -d' ' -f1 /proc/uptime) s"
poweroff -f
INIT
  chmod +x "$staging/init"
  (cd "$staging" && find . | cpio -o -H newc 2>/dev/null | gzip -1) >"$initrd.tmp"
  mv "$initrd.tmp" "$initrd"
  rm -rf "$staging"
  trap - EXIT
fi

# --- run
mkdir -p "$out"
rm -f "$out/vm-exit-code" "$out/vm-console.log"
{
  printf 'export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin\n'
  printf 'export VM_MODPROBE="modprobe -d /run/vm"\n'
  printf 'sh %q /mnt' "$script"
  for arg in "$@"; do printf ' %q' "$arg"; done
  printf '\n'
} >"$out/vm-command"
# One vCPU by default: with two, multi-threaded TCG on a busy 2-core host spent
# its whole time limit in RCU stalls and ran no scenario; with one it boots in
# seconds and passes while other processes use the host (docs/capture.md).
smp="${DFSM_VM_CPUS:-1}"
started=$(date +%s.%N)
set +e
timeout "$timeout_s" qemu-system-x86_64 -nodefaults -no-user-config -nographic -no-reboot \
  -accel tcg,thread=multi -cpu max -smp "$smp" -m "${DFSM_VM_MEMORY:-2048}" \
  -kernel "$vmlinuz" -initrd "$initrd" \
  -append "console=ttyS0 rdinit=/init quiet panic=-1 oops=panic" \
  -serial stdio -monitor none \
  -virtfs local,path=/,mount_tag=hostroot,security_model=none,readonly=on,multidevs=remap \
  -virtfs local,path="$out",mount_tag=out,security_model=none \
  >"$out/vm-serial.log" 2>&1
qemu_status=$?
set -e
ended=$(date +%s.%N)
echo "vm_run: qemu exited $qemu_status after $(echo "$ended - $started" | bc) s" >&2
if [ "$qemu_status" = 124 ]; then
  echo "vm_run: the VM ran past ${timeout_s} s; serial log:" >&2
  tail -20 "$out/vm-serial.log" >&2
  exit 124
fi
if [ ! -f "$out/vm-exit-code" ]; then
  echo "vm_run: the script did not finish; serial log:" >&2
  tail -30 "$out/vm-serial.log" >&2
  exit 1
fi
exit "$(cat "$out/vm-exit-code")"
