#!/usr/bin/env bash
# Rehearses a slower or busier machine of the project's class for one
# command (the README's test command, a test binary, a benchmark):
#   scripts/slow_machine.sh [--cpus X] [--load N] -- COMMAND [ARGS...]
#   --cpus X  the command and its children get X CPUs' worth of time: a CFS
#             quota on a cgroup of their own (cgroup v2, or v1's cpu
#             controller; needs root). On 2 cores, --cpus 1.38 is a machine
#             1.45x slower than this one; the quota is enforced per 100 ms,
#             so a busy command also sees stalls of tens of ms, as on a
#             shared host. SCHED_FIFO threads (the loop's tests) are not
#             held to the quota: on cgroup v1 they get half of each second.
#   --load N  N busy loops beside the command, at its priority: another job
#             on the machine (--load 2 keeps both cores busy).
# The command's exit status is the script's; on SIGINT, SIGTERM or SIGHUP
# the command is stopped (SIGTERM) and waited for; the loops and the cgroup
# go when it ends.
set -euo pipefail
usage="scripts/slow_machine.sh [--cpus X] [--load N] -- COMMAND [ARGS...]"
cpus=""
load=0
while (($#)); do
  case "$1" in
    --cpus) cpus="${2:?--cpus needs a number of CPUs}"; shift 2 ;;
    --load) load="${2:?--load needs a number of loops}"; shift 2 ;;
    --) shift; break ;;
    *) echo "slow_machine.sh: unknown option '$1'; usage: $usage" >&2; exit 2 ;;
  esac
done
if (($# == 0)); then
  echo "slow_machine.sh: no command after --; usage: $usage" >&2
  exit 2
fi
if [[ ! "$load" =~ ^[0-9]+$ ]]; then
  echo "slow_machine.sh: --load '$load' is not a whole number of loops" >&2
  exit 2
fi

loops=()
group=""
cleanup() {
  for pid in "${loops[@]}"; do kill "$pid" 2>/dev/null || true; done
  if [[ -n "$group" && -d "$group" ]]; then
    # Whatever is left in the group goes back to its parent first.
    while read -r pid; do
      echo "$pid" >"$(dirname "$group")/cgroup.procs" 2>/dev/null || true
    done <"$group/cgroup.procs"
    rmdir "$group" 2>/dev/null || true
  fi
}
trap cleanup EXIT

make_group() {
  local quota
  quota=$(awk -v c="$cpus" 'BEGIN { q = int(c * 100000); if (q < 1000) exit 1; print q }') ||
    { echo "slow_machine.sh: --cpus '$cpus' is not a number of CPUs >= 0.01" >&2; exit 2; }
  if [[ -f /sys/fs/cgroup/cgroup.controllers ]]; then
    group=/sys/fs/cgroup/kcrig-slow-$$
    echo +cpu >/sys/fs/cgroup/cgroup.subtree_control 2>/dev/null || true
    mkdir "$group"
    if [[ ! -f "$group/cpu.max" ]]; then
      echo "slow_machine.sh: cgroup v2 without the cpu controller for $group (cgroup.subtree_control)" >&2
      exit 2
    fi
    echo "$quota 100000" >"$group/cpu.max"
  elif [[ -d /sys/fs/cgroup/cpu ]]; then
    group=/sys/fs/cgroup/cpu/kcrig-slow-$$
    mkdir "$group"
    echo 100000 >"$group/cpu.cfs_period_us"
    echo "$quota" >"$group/cpu.cfs_quota_us"
    # With real-time group scheduling a new group has no real-time budget:
    # give it half of each period, so that SCHED_FIFO (the loop's tests)
    # works inside as it does outside. (The kernel refuses a budget while a
    # removed group's is not yet returned: a smaller one then, else a
    # warning.)
    if [[ -f "$group/cpu.rt_runtime_us" ]]; then
      for budget in 500000 200000 50000 0; do
        if ((budget == 0)); then
          echo "slow_machine.sh: warning: no real-time budget for the group; SCHED_FIFO is refused inside" >&2
        elif echo "$budget" >"$group/cpu.rt_runtime_us" 2>/dev/null; then
          break
        fi
      done
    fi
  else
    echo "slow_machine.sh: no cgroup cpu controller here; use --load" >&2
    exit 2
  fi
}

if [[ -n "$cpus" ]]; then make_group; fi
for ((k = 0; k < load; k++)); do
  (while :; do :; done) &
  loops+=($!)
done
echo "slow_machine.sh: ${cpus:-all} CPUs for the command${group:+ (cgroup $group)}, ${load} busy loops beside it"

(
  if [[ -n "$group" ]]; then
    echo "$BASHPID" >"$group/cgroup.procs" ||
      { echo "slow_machine.sh: could not join $group" >&2; exit 125; }
  fi
  exec "$@"
) &
child=$!
trap 'kill -TERM "$child" 2>/dev/null || true' INT TERM HUP
status=0
# A trapped signal ends the first wait early; wait again for the command.
wait "$child" || status=$?
while kill -0 "$child" 2>/dev/null; do wait "$child" || status=$?; done
exit "$status"
