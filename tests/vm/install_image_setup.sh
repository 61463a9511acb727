#!/bin/sh
# mmdebstrap customize hook of install_test.sh: makes the image a camera board
# with vivid as its camera, after the dfsmd .deb was installed into it by apt.
#
#   install_image_setup.sh ROOTFS KERNEL_MODULE_DIR MODULE_LIST
#
# MODULE_LIST: module paths relative to KERNEL_MODULE_DIR (vivid and what it
# needs, virtio, ext4) copied into ROOTFS/lib/modules/<kver> (the image boots
# the VM harness' kernel from outside, so it carries only these modules).
set -eu
rootfs="$1"
moddir="$2"
list="$3"
kver="$(basename "$moddir")"

# --- the kernel's modules, as a kernel package would leave them
while read -r rel; do
  [ -n "$rel" ] || continue
  mkdir -p "$rootfs/lib/modules/$kver/$(dirname "$rel")"
  cp "$moddir/$rel" "$rootfs/lib/modules/$kver/$rel"
done <"$list"
cp "$moddir"/modules.builtin* "$moddir"/modules.order "$rootfs/lib/modules/$kver/"
depmod -b "$rootfs" "$kver"

# --- vivid at boot: one device, one webcam input (/dev/video0)
echo vivid >"$rootfs/etc/modules-load.d/dfsm-vivid.conf"
echo "options vivid n_devs=1 node_types=0x1 num_inputs=1 input_types=0x0" >"$rootfs/etc/modprobe.d/dfsm-vivid.conf"

# --- the camera configuration: what a user edits after `apt install` (the
# package reads v4l2:/dev/video0 already); a small frame for the emulated CPU.
config="$rootfs/etc/dfsmd/dfsmd.toml"
grep -qx 'source = "v4l2:/dev/video0"' "$config"
sed -i -e 's/^width = 0$/width = 640/' -e 's/^height = 0$/height = 360/' -e 's/^fps = 0.0$/fps = 10.0/' \
  -e 's/^ring_frames = 64$/ring_frames = 32/' "$config"
grep -qx 'width = 640' "$config" && grep -qx 'height = 360' "$config" && grep -qx 'fps = 10.0' "$config"
chroot "$rootfs" /usr/bin/dfsmd --config /etc/dfsmd/dfsmd.toml --check-config

# --- the system
echo dfsm-install >"$rootfs/etc/hostname"
printf '127.0.0.1\tlocalhost\n127.0.1.1\tdfsm-install\n' >"$rootfs/etc/hosts"
printf '/dev/vda\t/\text4\trw,noatime\t0\t0\n' >"$rootfs/etc/fstab"
# Nothing else may take the dpkg lock or the console (ttyS0 on amd64, ttyAMA0 on
# arm64) during the test.
for unit in apt-daily.timer apt-daily-upgrade.timer serial-getty@ttyS0.service serial-getty@ttyAMA0.service \
  getty@tty1.service; do
  ln -sf /dev/null "$rootfs/etc/systemd/system/$unit"
done

# --- the check: a oneshot unit after dfsmd that prints to the serial console
cat >"$rootfs/etc/systemd/system/dfsm-install-check.service" <<'UNIT'
[Unit]
Description=dfsm install test (tests/vm/install_check.sh)
After=dfsmd.service
Wants=dfsmd.service

[Service]
Type=oneshot
ExecStart=/usr/local/sbin/install_check.sh
StandardOutput=journal+console
StandardError=journal+console
TimeoutStartSec=infinity

[Install]
WantedBy=multi-user.target
UNIT
chmod 755 "$rootfs/usr/local/sbin/install_check.sh"
mkdir -p "$rootfs/etc/systemd/system/multi-user.target.wants"
ln -sf /etc/systemd/system/dfsm-install-check.service \
  "$rootfs/etc/systemd/system/multi-user.target.wants/dfsm-install-check.service"
# The package enabled dfsmd at install (dh_installsystemd), as on a board.
test -L "$rootfs/etc/systemd/system/multi-user.target.wants/dfsmd.service"
