#!/bin/busybox sh
# /init of the test VM (tests/vm/prepare.sh puts it in the initramfs): mounts
# the kernel file systems, loads vivid and gpio-sim-collide, runs each test
# program listed in /tests/run.list and powers off. The host (tests/vm/run.sh)
# reads the serial console: every line of ours starts with "@@COLLIDE-VM".
/bin/busybox --install -s /bin
export PATH=/bin
export LD_LIBRARY_PATH=/lib/x86_64-linux-gnu:/usr/lib/x86_64-linux-gnu:/lib64
mkdir -p /proc /sys /dev /tmp
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
mount -t tmpfs tmpfs /tmp
echo "@@COLLIDE-VM kernel $(uname -r), $(nproc) CPUs, $(cat /proc/cmdline)"

while read -r ko args; do
  [ -n "$ko" ] || continue
  # shellcheck disable=SC2086
  insmod "/modules/$ko" $args || echo "@@COLLIDE-VM insmod $ko failed"
done < /modules/order
ls /dev/video* /dev/gpiochip* 2>/dev/null | tr '\n' ' ' | sed 's/^/@@COLLIDE-VM devices: /'
echo

if [ -f /tests/run.list ]; then
  while read -r prog args; do
    [ -n "$prog" ] || continue
    echo "@@COLLIDE-VM BEGIN $prog"
    # shellcheck disable=SC2086
    "/tests/$prog" $args </dev/null
    echo "@@COLLIDE-VM END $prog rc=$?"
  done < /tests/run.list
else
  echo "@@COLLIDE-VM no /tests/run.list: nothing to run"
fi
echo "@@COLLIDE-VM DONE"
sync
poweroff -f
