#include "rt_core/runtime/clock.h"

#include <cerrno>
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
}

}  // namespace kcrig
