#include "rt_core/runtime/cycle_timer.h"

#include <algorithm>
#include <ctime>

namespace kcrig {

std::int64_t MonotonicNanoseconds() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

CycleTimer::CycleTimer(std::int64_t period_ns, std::int64_t last_cycle,
                       Clock* clock)
    : period_(period_ns),
      last_cycle_(last_cycle),
      clock_(clock != nullptr ? clock : SystemClock()) {}

void CycleTimer::Start() {
  next_deadline_ = clock_->Now() + period_;
  next_cycle_ = 0;
}

CycleTimer::Wake CycleTimer::WaitForNextCycle() {
  Wake wake;
  const std::int64_t now = clock_->Now();
  if (now > next_deadline_) {
    // The last cycle ran past the next deadline: skip to the first deadline
    // still ahead rather than running late cycles back to back, but never
    // past the run's last cycle (after it, as in a trip's ramp-down, skip).
    std::int64_t missed = (now - next_deadline_) / period_ + 1;
    if (next_cycle_ <= last_cycle_) {
      missed = std::min(missed, last_cycle_ - next_cycle_);
    }
    // The machine woke the previous cycle last_latency_ late, one period
    // before next_deadline_: the deadlines it had passed by then.
    const std::int64_t missed_waking =
        last_latency_ > period_ ? (last_latency_ - period_) / period_ + 1 : 0;
    skipped_late_ += std::min(missed, missed_waking);
    next_deadline_ += missed * period_;
    next_cycle_ += missed;
    wake.skipped = missed;
    skipped_ += missed;
    ++overruns_;
  }
  clock_->SleepUntil(next_deadline_);
  const std::int64_t woke = clock_->Now();
  wake.cycle = next_cycle_;
  wake.deadline = next_deadline_;
  wake.latency = woke - next_deadline_;
  wake.wakeup_latency = woke - std::max(next_deadline_, now);
  last_latency_ = wake.wakeup_latency;
  next_deadline_ += period_;
  ++next_cycle_;
  return wake;
}

TimingStatistics MeasureWakeupLatency(std::int64_t period_ns,
                                      double duration_s) {
  TimingStatistics latency;
  MonotonicClock* clock = SystemClock();
  const auto cycles = static_cast<std::int64_t>(duration_s * 1e9 / period_ns);
  std::int64_t deadline = clock->Now() + period_ns;
  for (std::int64_t k = 0; k < cycles; ++k) {
    clock->SleepUntil(deadline);
    latency.Record(clock->Now() - deadline);
    deadline += period_ns;
  }
  return latency;
}

}  // namespace kcrig
