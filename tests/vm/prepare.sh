#!/usr/bin/env bash
# Prepares what the kernel-driver tests (CTest label `vm`) boot: Debian's own
# 6.1 kernel (linux-image-6.1.0-*-amd64), the project's gpio-sim-collide
# module built against the matching linux-headers, and a small base initramfs
# (busybox-static, vivid and its dependencies, the module, tests/vm/init.sh).
# tests/vm/run.sh appends the test programs and their libraries at run time.
#
#   tests/vm/prepare.sh [OUT_DIR]      default OUT_DIR: build/vm-image
#
# Idempotent: does nothing when OUT_DIR is up to date with the kernel and the
# sources. Exit status 0: ready; 77: cannot prepare on this machine (the
# message says which package is missing; collide.sh installs them); other:
# a real failure (e.g. the module does not compile).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
out="${1:-$here/../../build/vm-image}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
export PATH="$PATH:/usr/sbin:/sbin"

skip() {
  echo "vm: cannot prepare the test VM here: $*" >&2
  exit 77
}

command -v qemu-system-x86_64 >/dev/null || skip "qemu-system-x86_64 is missing (Debian package qemu-system-x86)"
[ -x /bin/busybox ] && dpkg-query -W -f='${Status}' busybox-static 2>/dev/null | grep -q "ok installed" ||
  skip "a static busybox is missing (Debian package busybox-static)"
command -v cpio >/dev/null || skip "cpio is missing (Debian package cpio)"
command -v modprobe >/dev/null || skip "modprobe is missing (Debian package kmod)"
command -v make >/dev/null && command -v gcc >/dev/null || skip "make and gcc are missing (build-essential)"

# The newest 6.1 kernel that has its modules, its image and matching headers.
ver=""
for dir in $(ls -d /usr/src/linux-headers-6.1.0-*-amd64 2>/dev/null | sort -V -r); do
  v="${dir#/usr/src/linux-headers-}"
  if [ -e "/boot/vmlinuz-$v" ] && [ -d "/lib/modules/$v/kernel" ]; then
    ver="$v"
    break
  fi
done
[ -n "$ver" ] || skip "no Debian 6.1 kernel with matching headers: install linux-image-amd64 and linux-headers-amd64 (the same version)"
if [ ! -r "/boot/vmlinuz-$ver" ] && ! [ -f "$out/vmlinuz" -a "$(cat "$out/kernel-version" 2>/dev/null)" = "$ver" ]; then
  skip "/boot/vmlinuz-$ver is readable by root only (Debian's default): run ./collide.sh test as root once, or make it readable (sudo chmod 644 /boot/vmlinuz-$ver)"
fi

# vivid with the modules it needs, in load order, and its options: two
# devices, video capture only, one webcam input each; /dev/video0 is
# single-planar (what cameras and Collide use), /dev/video1 multi-planar only
# (which Collide refuses, clearly).
vivid_deps="$(modprobe -S "$ver" --show-depends vivid 2>/dev/null | awk '$1 == "insmod" {print $2}')" ||
  skip "modprobe cannot resolve vivid for kernel $ver"
[ -n "$vivid_deps" ] || skip "kernel $ver has no vivid module"
vivid_args="n_devs=2 node_types=0x1,0x1 multiplanar=1,2 num_inputs=1,1 input_types=0x0,0x0"
# The GPIO chip: four valve lines; lines 2 and 3 are pulled up (they serve
# the active-low valves: a released line then reads inactive, as on a rig
# wired with pull resistors).
gpio_args="nlines=4 line_names=VALVE_A,VALVE_B,VALVE_C,VALVE_D pull_up_mask=0xc"

stamp="$( {
  echo "$ver"
  echo "$vivid_deps $vivid_args $gpio_args"
  cat "$here/gpio-sim-collide/gpio-sim-collide.c" "$here/gpio-sim-collide/Kbuild" "$here/init.sh" "$0"
  stat -c '%s %Y' "/boot/vmlinuz-$ver" /bin/busybox 2>/dev/null
} | sha256sum | cut -d' ' -f1)"
if [ -f "$out/stamp" ] && [ "$(cat "$out/stamp")" = "$stamp" ] && [ -f "$out/base.cpio" ] &&
  [ -f "$out/vmlinuz" ]; then
  echo "vm: test VM ready in $out (kernel $ver)"
  exit 0
fi

echo "vm: preparing the test VM in $out (kernel $ver)"
rm -rf "$out/module" "$out/root"
mkdir -p "$out/module" "$out/root/bin" "$out/root/modules"
cp "$here/gpio-sim-collide/gpio-sim-collide.c" "$here/gpio-sim-collide/Kbuild" "$out/module/"
if ! make -C "/usr/src/linux-headers-$ver" M="$out/module" modules >"$out/module/build.log" 2>&1; then
  cat "$out/module/build.log" >&2
  echo "vm: building tests/vm/gpio-sim-collide against linux-headers-$ver failed" >&2
  exit 1
fi

cp /bin/busybox "$out/root/bin/busybox"
cp "$here/init.sh" "$out/root/init"
chmod 755 "$out/root/init"
: >"$out/root/modules/order"
for ko in $vivid_deps; do
  name="$(basename "$ko")"
  cp "$ko" "$out/root/modules/$name"
  if [ "$name" = "vivid.ko" ]; then
    echo "$name $vivid_args" >>"$out/root/modules/order"
  else
    echo "$name" >>"$out/root/modules/order"
  fi
done
cp "$out/module/gpio-sim-collide.ko" "$out/root/modules/"
echo "gpio-sim-collide.ko $gpio_args" >>"$out/root/modules/order"

(cd "$out/root" && find . | LC_ALL=C sort | cpio -o -H newc --quiet --owner=0:0) >"$out/base.cpio.tmp"
mv "$out/base.cpio.tmp" "$out/base.cpio"
[ -r "/boot/vmlinuz-$ver" ] && cp "/boot/vmlinuz-$ver" "$out/vmlinuz"
echo "$ver" >"$out/kernel-version"
echo "$stamp" >"$out/stamp"
echo "vm: test VM ready in $out (kernel $ver, $(du -h "$out/base.cpio" | cut -f1) base initramfs)"
