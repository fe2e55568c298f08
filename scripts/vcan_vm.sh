#!/usr/bin/env bash
# Runs a command where a vcan0 interface exists.
#
#   scripts/vcan_vm.sh prepare           fetch the guest kernel, build the initramfs
#   scripts/vcan_vm.sh run CMD [ARG...]  run CMD with vcan0 up; exits with CMD's status
#
# Where the host kernel has CAN (a rig PC: `ip link add dev vcan0 type vcan`
# works), CMD runs directly on the host's vcan0. Otherwise (this machine: no
# CAN in the kernel, no KVM) it runs inside Debian's own kernel under qemu
# with TCG: linux-image-amd64 fetched with `apt-get download` and unpacked
# with `dpkg -x` (not installed), an initramfs of busybox-static and the CAN
# and 9p modules, the host root shared read-only over 9p, and a writable
# scratch directory ($KCRIG_VM_SCRATCH in the guest, also on the host).
# The guest loads the modules, brings vcan0 up, chroots into the host root,
# runs CMD in the caller's working directory and prints its exit status on
# the serial console; this script returns it. A guest that does not report
# one (boot failure, timeout) is an error (125), never a pass.
#
# The guest is paced by guest time, not the host's: one vCPU under
# `-icount shift=1,sleep=off`, so its clock advances 2 ns per executed
# instruction (a steady 500 MIPS machine) and jumps over idle time. A host
# that deschedules qemu stops the guest's clock with it, so a busy host
# makes a run longer, never late: the guest's 1 kHz loop keeps its period
# and the tests keep rig.yaml's watchdog and tracking limits. The price:
# guest time says nothing about a real machine's latency, and it races
# ahead while the guest waits for the host (9p reads), so waits in the
# guest are for a state, not a duration.
#
# Environment: KCRIG_VM_CACHE (default ~/.cache/kcrig-vm),
# KCRIG_VM_TIMEOUT [s] (default 900), KCRIG_VM_FORCE=1 (use the VM even
# where the host has vcan), KCRIG_VM_KEEP=1 (keep the scratch directory,
# for a look at what the guest wrote).
set -euo pipefail

cache=${KCRIG_VM_CACHE:-${HOME:-/root}/.cache/kcrig-vm}
# In load order; sch_prio, cls_basic, em_canid and sch_tbf let a test fill
# the transmit queue of the controller's frames alone (ENOBUFS).
modules=(virtio_ring virtio virtio_pci_modern_dev virtio_pci_legacy_dev
  virtio_pci netfs fscache 9pnet 9pnet_virtio 9p can can-raw can-dev vcan
  sch_prio cls_basic em_canid sch_tbf)

die() {
  echo "vcan_vm: $*" >&2
  exit 125
}

as_root() {
  if [[ $(id -u) -eq 0 ]]; then "$@"; else sudo "$@"; fi
}

prepare() {
  # Rebuilt whenever this script (module list, guest init) changes.
  local stamp
  stamp=$(sha256sum "${BASH_SOURCE[0]}" | cut -d' ' -f1)
  [[ -f $cache/ready && $(cat "$cache/ready") == "$stamp" ]] && return 0
  command -v qemu-system-x86_64 >/dev/null || die "qemu-system-x86_64 missing (scripts/setup.sh installs qemu-system-x86)"
  [[ -x /bin/busybox ]] || die "/bin/busybox missing (scripts/setup.sh installs busybox-static)"
  mkdir -p "$cache"
  local work
  work=$(mktemp -d "$cache/prepare.XXXXXX")
  trap 'rm -rf "$work"' RETURN
  local package
  package=$(apt-cache depends linux-image-amd64 2>/dev/null |
    awk '/Depends: linux-image-[0-9]/ {print $2; exit}')
  [[ -n $package ]] || die "apt-cache knows no linux-image-amd64 (run apt-get update)"
  echo "vcan_vm: fetching $package"
  (cd "$work" && apt-get download -q "$package" >/dev/null 2>&1) ||
    (cd "$work" && as_root apt-get update -qq && apt-get download -q "$package" >/dev/null) ||
    die "apt-get download $package failed"
  dpkg -x "$work"/"$package"_*.deb "$work/kernel"
  local release
  release=$(basename "$work"/kernel/lib/modules/*)
  local initramfs=$work/initramfs
  mkdir -p "$initramfs"/{bin,dev,proc,sys,host,modules}
  cp /bin/busybox "$initramfs/bin/busybox"
  for m in "${modules[@]}"; do
    local ko
    ko=$(find "$work/kernel/lib/modules/$release" -name "$m.ko*" | head -1)
    [[ -n $ko ]] || die "module $m not in $package"
    case $ko in
      *.ko) cp "$ko" "$initramfs/modules/$m.ko" ;;
      *.ko.xz) xz -dc "$ko" >"$initramfs/modules/$m.ko" ;;
      *.ko.zst) zstd -qdc "$ko" >"$initramfs/modules/$m.ko" ;;
      *) die "cannot unpack $ko" ;;
    esac
  done
  cat >"$initramfs/init" <<'EOF'
#!/bin/busybox sh
/bin/busybox --install -s /bin
export PATH=/bin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
say() { echo "$*" >/dev/ttyS0; }
job=$(sed -n 's/.*kcrig_job=\([^ ]*\).*/\1/p' /proc/cmdline)
scratch=$(sed -n 's/.*kcrig_scratch=\([^ ]*\).*/\1/p' /proc/cmdline)
keep=$(sed -n 's/.*kcrig_keep=\([^ ]*\).*/\1/p' /proc/cmdline | tr ',' ' ')
for m in $(cat /modules/order); do
  insmod /modules/$m.ko || say "KCRIG_VM_ERROR insmod $m"
done
mount -t 9p -o trans=virtio,version=9p2000.L,msize=262144,cache=loose,ro host /host ||
  say "KCRIG_VM_ERROR mount host"
mount -t proc proc /host/proc
mount -t sysfs sys /host/sys
mount -t devtmpfs dev /host/dev
mkdir -p /host/dev/shm /host/dev/pts
mount -t tmpfs shm /host/dev/shm
# The guest's /tmp is its own tmpfs; host folders under /tmp that the job
# needs (a checkout there) stay visible through bind mounts.
i=0
for p in $keep; do
  mkdir -p /keep/$i && mount -o bind "/host$p" /keep/$i || say "KCRIG_VM_ERROR keep $p"
  i=$((i + 1))
done
mount -t tmpfs tmp /host/tmp
i=0
for p in $keep; do
  mkdir -p "/host$p" && mount -o bind /keep/$i "/host$p"
  i=$((i + 1))
done
mount -t tmpfs run /host/run
mkdir -p "/host$scratch"
mount -t 9p -o trans=virtio,version=9p2000.L,msize=262144 scratch "/host$scratch" ||
  say "KCRIG_VM_ERROR mount scratch"
ip link set lo up
ip link add dev vcan0 type vcan && ip link set up vcan0 ||
  say "KCRIG_VM_ERROR vcan0"
chroot /host /bin/sh "$job" >"/host$scratch/output" 2>&1
say "KCRIG_VM_EXIT=$?"
sync
poweroff -f
EOF
  chmod +x "$initramfs/init"
  echo "${modules[*]}" >"$initramfs/modules/order"
  (cd "$initramfs" && find . | cpio -o -H newc --quiet | gzip -1) >"$work/initramfs.cpio.gz"
  cp "$work"/kernel/boot/vmlinuz-* "$cache/vmlinuz"
  mv "$work/initramfs.cpio.gz" "$cache/initramfs.cpio.gz"
  echo "$stamp" >"$cache/ready"
  echo "vcan_vm: guest kernel $release ready in $cache"
}

host_has_vcan() {
  [[ ${KCRIG_VM_FORCE:-0} == 1 ]] && return 1
  ip link show vcan0 >/dev/null 2>&1 && return 0
  as_root ip link add dev vcan0 type vcan >/dev/null 2>&1 &&
    as_root ip link set up vcan0 && return 0
  return 1
}

run() {
  (($# > 0)) || die "usage: vcan_vm.sh run CMD [ARG...]"
  if host_has_vcan; then
    export KCRIG_VM_SCRATCH=${KCRIG_VM_SCRATCH:-$(mktemp -d)}
    exec "$@"
  fi
  prepare
  local scratch
  scratch=$(mktemp -d "${TMPDIR:-/tmp}/kcrig-vm.XXXXXX")
  if [[ ${KCRIG_VM_KEEP:-0} == 1 ]]; then
    echo "vcan_vm: keeping the scratch directory $scratch" >&2
  else
    trap 'rm -rf "$scratch"' EXIT
  fi
  {
    echo "cd $(printf %q "$PWD") || exit 126"
    echo "export PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"
    echo "export HOME=/tmp TMPDIR=/tmp KCRIG_VM_SCRATCH=$(printf %q "$scratch") KCRIG_IN_VM=1"
    for v in GTEST_FILTER GTEST_COLOR KCRIG_TEST_ARGS; do
      [[ -n ${!v:-} ]] && echo "export $v=$(printf %q "${!v}")"
    done
    printf 'exec'
    printf ' %q' "$@"
    echo
  } >"$scratch/job.sh"
  # Host folders under /tmp that the job needs: the caller's directory, this
  # checkout and the command's own.
  local keep=() p top
  for p in "$PWD" "$(cd "$(dirname "$0")/.." && pwd)" "$(dirname "$(readlink -f "$1" 2>/dev/null || echo "$1")")"; do
    [[ $p == /tmp/* ]] || continue
    top=/tmp/$(echo "${p#/tmp/}" | cut -d/ -f1)
    [[ $top =~ [[:space:],] ]] && die "$top: a path with spaces or commas cannot be shared with the guest"
    [[ " ${keep[*]} " == *" $top "* ]] || keep+=("$top")
  done
  local keep_list
  keep_list=$(IFS=,; echo "${keep[*]}")
  local console=$scratch/console
  local status=0
  # In the caller's process group, so that killing that group ends the guest.
  timeout --foreground "${KCRIG_VM_TIMEOUT:-900}" qemu-system-x86_64 -accel tcg -icount shift=1,sleep=off \
    -m 1536 -smp 1 -nographic -no-reboot -nic none \
    -kernel "$cache/vmlinuz" -initrd "$cache/initramfs.cpio.gz" \
    -append "console=ttyS0 quiet loglevel=3 panic=-1 kcrig_job=$scratch/job.sh kcrig_scratch=$scratch kcrig_keep=$keep_list" \
    -virtfs local,path=/,mount_tag=host,security_model=none,readonly=on,multidevs=remap \
    -virtfs "local,path=$scratch,mount_tag=scratch,security_model=none,multidevs=remap" \
    </dev/null >"$console" 2>&1 || status=$?
  [[ -f $scratch/output ]] && cat "$scratch/output"
  if grep -q KCRIG_VM_ERROR "$console"; then
    grep KCRIG_VM_ERROR "$console" >&2
  fi
  local code
  code=$(sed -n 's/.*KCRIG_VM_EXIT=\([0-9]*\).*/\1/p' "$console" | tail -1)
  if [[ -z $code ]]; then
    echo "--- guest console ---" >&2
    tail -n 40 "$console" >&2
    die "the guest reported no exit status (qemu status $status)"
  fi
  exit "$code"
}

case ${1:-} in
  prepare) prepare ;;
  run)
    shift
    run "$@"
    ;;
  *) die "usage: vcan_vm.sh prepare | run CMD [ARG...]" ;;
esac
