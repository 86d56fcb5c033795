#!/usr/bin/env bash
# Boots the test VM (tests/vm/prepare.sh) under qemu-system-x86_64 -accel tcg
# with one test program inside, runs it there and reports its result.
#
#   tests/vm/run.sh IMAGE_DIR PROGRAM [ARGS...]
#
# The program and the shared libraries ldd finds for it are appended to the
# base initramfs as a second cpio archive (the kernel unpacks both). The VM's
# serial console comes back on stdout; the exit status is the program's.
# 77: the VM cannot run on this machine (prepare.sh says why).
# Environment: COLLIDE_VM_TIMEOUT (seconds, default 480), COLLIDE_VM_SMP (2).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
[ $# -ge 2 ] || { sed -n '2,12p' "$0"; exit 2; }
img="$1"
prog="$2"
shift 2

"$here/prepare.sh" "$img"
[ -x "$prog" ] || { echo "vm: no test program $prog: build it first" >&2; exit 1; }

work="$(mktemp -d "${TMPDIR:-/tmp}/collide-vm.XXXXXX")"
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/root/tests"
cp "$prog" "$work/root/tests/"
name="$(basename "$prog")"
echo "$name $*" >"$work/root/tests/run.list"
# The program's shared libraries at the paths the loader looks for them.
ldd "$prog" | awk '/=> \// {print $3} /^\t\/[^ ]+ \(0x/ {print $1}' | sort -u | while read -r lib; do
  mkdir -p "$work/root$(dirname "$lib")"
  cp -L "$lib" "$work/root$lib"
done
(cd "$work/root" && find . | LC_ALL=C sort | cpio -o -H newc --quiet --owner=0:0) >"$work/tests.cpio"
cat "$img/base.cpio" "$work/tests.cpio" >"$work/initrd.cpio"
echo "vm: booting $(cat "$img/kernel-version") with $name ($(du -h "$work/tests.cpio" | cut -f1) of program and libraries)"

start=$(date +%s)
status=0
timeout "${COLLIDE_VM_TIMEOUT:-480}" qemu-system-x86_64 \
  -accel tcg -cpu max -smp "${COLLIDE_VM_SMP:-2}" -m 1024 \
  -kernel "$img/vmlinuz" -initrd "$work/initrd.cpio" \
  -append "console=ttyS0 quiet loglevel=3 panic=-1" \
  -display none -monitor none -serial stdio -no-reboot -nodefaults \
  </dev/null | tr -d '\r' | tee "$work/console.log" || status=$?
echo "vm: the VM ran $(($(date +%s) - start)) s"
if [ "$status" -eq 124 ]; then
  echo "vm: the VM did not finish within ${COLLIDE_VM_TIMEOUT:-480} s" >&2
  exit 1
fi
rc="$(sed -n "s/^@@COLLIDE-VM END $name rc=\([0-9]*\)$/\1/p" "$work/console.log" | tail -1)"
if [ -z "$rc" ]; then
  echo "vm: $name did not finish inside the VM (see the console above)" >&2
  exit 1
fi
exit "$rc"
