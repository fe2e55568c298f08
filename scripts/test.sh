#!/usr/bin/env bash
# Quick start (2): installs the dependencies, builds Release (g++) and the
# AddressSanitizer + UBSan preset (clang), and runs the test suite under both, then
# the libFuzzer targets (clang) for a short time each.
#   scripts/test.sh          CI tier (labels ci, ci-statistical, ci-heavy,
#                            ci-realtime, ci-vcan, ci-loopback,
#                            ci-package); under the
#                            sanitizers the statistical and heavy ones
#                            (hundreds of seeded re-estimations, long
#                            profiles: numbers, not memory), the real-time
#                            tests (1 kHz processes, in-process rigs in
#                            real time: deadlines), the vcan
#                            tests (a VM under TCG) and the Debian package
#                            (a Release artefact) are left to Release, and
#                            only what the sanitizer tier runs is built
#                            there (ci_tier_tests; line tables, -g1); in
#                            Release what the ci* labels run
#                            (ci_release_tests: no benchmarks, no full
#                            tiers' binaries)
#   scripts/test.sh --full   every tier under both presets
# The vcan tests need vcan0: scripts/vcan_vm.sh boots Debian's kernel under
# qemu where the host kernel has no CAN (its first run downloads the kernel
# package with apt-get).
set -euo pipefail
cd "$(dirname "$0")/.."
full=0
if [[ "${1:-}" == "--full" ]]; then full=1; fi

scripts/setup.sh
start=$SECONDS
for preset in release asan; do
  echo "== ${preset}: configure and build"
  cmake --preset "$preset" >/dev/null
  if ((full)); then
    cmake --build --preset "$preset"
  elif [[ "$preset" == release ]]; then
    cmake --build --preset "$preset" --target ci_release_tests
  else
    cmake --build --preset "$preset" --target ci_tier_tests
  fi
  echo "== ${preset}: test"
  if ((full)); then
    ctest --preset "$preset"
  elif [[ "$preset" == asan ]]; then
    ctest --preset "$preset" -L ci -LE 'statistical|heavy|realtime|vcan|browser|loopback'
    # The in-process Modbus master and rig, the rig on a virtual clock (its
    # real-time twins are ci-realtime: Release only); a stall of the machine
    # can still time a reply out, so a failed case runs once more.
    ctest --preset "$preset" -L ci-loopback --repeat until-pass:2
  else
    # The vcan tier runs beside the Release tier: its guest is paced by
    # guest time (scripts/vcan_vm.sh), so a busy host makes it longer, never
    # late, and its one vCPU would leave the other core idle if it ran
    # alone. A failed case runs once more, as below. In a session of its
    # own, so that an interrupted script takes it and its guest down too.
    vcan_log=build/vcan_tier.log
    setsid ctest --preset "$preset" -L ci-vcan --repeat until-pass:2 \
      >"$vcan_log" 2>&1 &
    vcan_pid=$!
    trap 'kill -- -"$vcan_pid" 2>/dev/null || true' EXIT
    tier_status=0
    ctest --preset "$preset" -L ci -LE 'realtime|vcan|loopback' ||
      tier_status=$?
    vcan_status=0
    wait "$vcan_pid" || vcan_status=$?
    trap - EXIT
    echo "== release: vcan tier (beside the tier above)"
    cat "$vcan_log"
    if ((tier_status != 0 || vcan_status != 0)); then exit 1; fi
    # The real-time tests (1 kHz processes, in-process rigs in real time)
    # and the loopback ones on a shared VM, alone: a host preemption
    # (wake-ups of several ms are measured here) can skip enough cycles to
    # fail a run that is otherwise right; a failed case runs once more, and
    # two failures fail.
    ctest --preset "$preset" -L 'ci-realtime|ci-loopback' --repeat until-pass:2
  fi
done
echo "== fuzz: configure, build and run each fuzzer"
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz
if ((full)); then
  ctest --preset fuzz
else
  ctest --preset fuzz -LE full-fuzz
fi
echo "== tests done in $((SECONDS - start)) s"
