// The loop's timing policy: absolute deadlines on a clock (CLOCK_MONOTONIC,
// slept to with clock_nanosleep(TIMER_ABSTIME), or the software rig's
// virtual one) so that the period never drifts with the cycle's own
// duration. A cycle that ends after the next deadline is an
// overrun: every deadline already passed is skipped (not caught up in a
// burst) and counted, and the loop resumes on the next one ahead. Skipped
// deadlines that the wake-up itself was already past are counted apart: the
// machine did not run the loop then (a host preemption, say), whatever the
// cycle's own work.
#ifndef KCRIG_RT_CORE_RUNTIME_CYCLE_TIMER_H_
#define KCRIG_RT_CORE_RUNTIME_CYCLE_TIMER_H_

#include <cstdint>

#include "rt_core/runtime/clock.h"
#include "rt_core/runtime/timing_statistics.h"

namespace kcrig {

// Monotonic time [ns].
std::int64_t MonotonicNanoseconds();

class CycleTimer {
 public:
  // `last_cycle`: the index of the run's last cycle, which is never
  // skipped: an overrun past its deadline runs it at once, late, so that a
  // run that ends on time always ends with its own last cycle (and its log
  // with its last row).
  // `clock`: the time the deadlines are on (null: CLOCK_MONOTONIC).
  explicit CycleTimer(std::int64_t period_ns,
                      std::int64_t last_cycle = INT64_MAX,
                      Clock* clock = nullptr);

  // The first deadline is one period from now; cycle 0 starts there.
  void Start();

  struct Wake {
    std::int64_t cycle = 0;     // index of the cycle that starts now
    std::int64_t deadline = 0;  // its nominal start [ns, on the clock]
    std::int64_t latency = 0;   // woke this long after the deadline [ns]
    // How late the machine woke the loop [ns]: after the deadline, or after
    // the call when the last cycle's deadline had passed already (the
    // loop's own overrun is not the machine's latency).
    std::int64_t wakeup_latency = 0;
    std::int64_t skipped = 0;  // deadlines missed since the last cycle
  };

  // Sleeps until the next deadline that is still ahead (skipping those that
  // have passed) and returns it.
  Wake WaitForNextCycle();

  std::int64_t period() const { return period_; }
  std::int64_t overruns() const { return overruns_; }
  std::int64_t skipped_cycles() const { return skipped_; }
  // Of skipped_cycles(): deadlines passed before the previous cycle woke.
  std::int64_t skipped_by_late_wakeup() const { return skipped_late_; }

 private:
  std::int64_t period_;
  std::int64_t last_cycle_;
  Clock* clock_;
  std::int64_t next_deadline_ = 0;
  std::int64_t next_cycle_ = 0;
  std::int64_t overruns_ = 0;
  std::int64_t skipped_ = 0;
  std::int64_t skipped_late_ = 0;
  std::int64_t last_latency_ = 0;  // previous wakeup_latency [ns]
};

// The machine's own wake-up latency, measured the way cyclictest does it:
// sleep to absolute deadlines `period_ns` apart for `duration_s`, doing no
// work, and record how late each wake-up is (on the calling thread, with
// its current scheduling). Tells the machine's limit from kcrig's cost.
TimingStatistics MeasureWakeupLatency(std::int64_t period_ns,
                                      double duration_s);

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_RUNTIME_CYCLE_TIMER_H_
