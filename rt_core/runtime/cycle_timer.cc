#include "rt_core/runtime/cycle_timer.h"

#include <algorithm>
#include <cerrno>
#include <ctime>

namespace kcrig {
namespace {

constexpr std::int64_t kNanosecondsPerSecond = 1000000000;

timespec ToTimespec(std::int64_t ns) {
  timespec ts;
  ts.tv_sec = static_cast<time_t>(ns / kNanosecondsPerSecond);
  ts.tv_nsec = static_cast<long>(ns % kNanosecondsPerSecond);
  return ts;
}

}  // namespace

std::int64_t MonotonicNanoseconds() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * kNanosecondsPerSecond +
         ts.tv_nsec;
}

void CycleTimer::Start() {
  next_deadline_ = MonotonicNanoseconds() + period_;
  next_cycle_ = 0;
}

CycleTimer::Wake CycleTimer::WaitForNextCycle() {
  Wake wake;
  const std::int64_t now = MonotonicNanoseconds();
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
  const timespec deadline = ToTimespec(next_deadline_);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr) ==
         EINTR) {
  }
  const std::int64_t woke = MonotonicNanoseconds();
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
  const auto cycles = static_cast<std::int64_t>(duration_s * 1e9 / period_ns);
  std::int64_t deadline = MonotonicNanoseconds() + period_ns;
  for (std::int64_t k = 0; k < cycles; ++k) {
    const timespec ts = ToTimespec(deadline);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) ==
           EINTR) {
    }
    latency.Record(MonotonicNanoseconds() - deadline);
    deadline += period_ns;
  }
  return latency;
}

}  // namespace kcrig
