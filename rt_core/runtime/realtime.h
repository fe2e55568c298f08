// Real-time set-up of the calling thread: SCHED_FIFO priority, CPU affinity,
// locked memory and a prefaulted stack. Each step that the system does not
// permit is reported, never silently dropped: the loop goes on without it and
// the warning appears on the terminal and in timing.json.
#ifndef KCRIG_RT_CORE_RUNTIME_REALTIME_H_
#define KCRIG_RT_CORE_RUNTIME_REALTIME_H_

#include <string>
#include <vector>

namespace kcrig {

struct RealtimeOptions {
  // SCHED_FIFO priority 1..99; 0 keeps the default time-sharing scheduler.
  int priority = 80;
  // CPU to pin the loop thread to; -1 leaves the affinity alone.
  int cpu = -1;
  // mlockall(MCL_CURRENT | MCL_FUTURE) so the cycle never page-faults.
  bool lock_memory = true;
  // Hold /dev/cpu_dma_latency at 0 us while the loop runs (as cyclictest
  // does): CPUs stay out of deep idle states whose exit costs wake-up
  // latency.
  bool no_cpu_idle = true;
};

struct RealtimeReport {
  bool fifo = false;                  // SCHED_FIFO at the requested priority
  bool affinity = false;              // pinned to the requested CPU
  bool locked = false;                // memory locked
  bool no_cpu_idle = false;           // /dev/cpu_dma_latency held at 0
  std::vector<std::string> warnings;  // one line per step not permitted
};

// Applies `options` to the calling thread (and the process for mlockall).
RealtimeReport SetUpRealtime(const RealtimeOptions& options);

// Returns the calling thread to the time-sharing scheduler, restores its CPU
// affinity, releases /dev/cpu_dma_latency and unlocks memory: the work after
// the loop (writing logs, estimating) must not starve others or stay pinned.
void LeaveRealtime();

// Takes `cpu` out of the calling thread's CPU affinity, unless it is the
// only one left (-1: nothing): the threads that serve a loop pinned there
// (its logger, the console) keep off its CPU and its caches. Best effort.
void KeepOffCpu(int cpu);

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_RUNTIME_REALTIME_H_
