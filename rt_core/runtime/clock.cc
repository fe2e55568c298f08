#include "rt_core/runtime/clock.h"

#include <cerrno>
#include <cmath>
#include <ctime>

#include "rt_core/runtime/cycle_timer.h"

namespace kcrig {

std::int64_t MonotonicClock::Now() const { return MonotonicNanoseconds(); }

void MonotonicClock::SleepUntil(std::int64_t deadline) {
  timespec ts;
  ts.tv_sec = static_cast<time_t>(deadline / 1000000000);
  ts.tv_nsec = static_cast<long>(deadline % 1000000000);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) ==
         EINTR) {
  }
}

MonotonicClock* SystemClock() {
  static MonotonicClock clock;
  return &clock;
}

void VirtualClock::SleepUntil(std::int64_t deadline) {
  std::int64_t now = now_.load();
  while (now < deadline && !now_.compare_exchange_weak(now, deadline)) {
  }
  if (pace_ > 0) Pace(deadline);
}

void VirtualClock::Pace(std::int64_t deadline) {
  // Further off the pace than this, either way, starts it afresh.
  constexpr std::int64_t kMaxBehind = 50'000'000;
  constexpr std::int64_t kMaxAhead = 1'500'000'000;
  const std::int64_t wall = MonotonicNanoseconds();
  const std::int64_t due =
      wall_anchor_ +
      std::llround(static_cast<double>(deadline - virtual_anchor_) / pace_);
  if (wall_anchor_ < 0 || wall - due > kMaxBehind || due - wall > kMaxAhead) {
    wall_anchor_ = wall;
    virtual_anchor_ = deadline;
    return;
  }
  if (due > wall) SystemClock()->SleepUntil(due);
}

}  // namespace kcrig
