// The time the loop runs on and the software rig advances to. A rig runs on
// CLOCK_MONOTONIC, slept on with clock_nanosleep(TIMER_ABSTIME). The
// software-in-the-loop rig runs on a VirtualClock that moves only when the
// loop sleeps on it or its owner advances it: a run goes as fast as the CPU
// allows, the same for a seed on any machine, and no host (a loaded
// machine, code under the sanitizers) can make the rig's plant fall behind
// its controller.
#ifndef KCRIG_RT_CORE_RUNTIME_CLOCK_H_
#define KCRIG_RT_CORE_RUNTIME_CLOCK_H_

#include <atomic>
#include <cstdint>

namespace kcrig {

class Clock {
 public:
  virtual ~Clock() = default;
  // The current time [ns], monotonic, any origin.
  virtual std::int64_t Now() const = 0;
  // Returns at `deadline` [ns] or later (at once when it has passed).
  virtual void SleepUntil(std::int64_t deadline) = 0;
  // Whether this is the wall's time, for which a real-time set-up pays.
  virtual bool real_time() const = 0;
  double Seconds() const { return static_cast<double>(Now()) * 1e-9; }
};

// Real time: CLOCK_MONOTONIC.
class MonotonicClock final : public Clock {
 public:
  std::int64_t Now() const override;
  void SleepUntil(std::int64_t deadline) override;
  bool real_time() const override { return true; }
};

// The process's monotonic clock, for those given no other.
MonotonicClock* SystemClock();

// Whether a loop given `clock` (nullptr: SystemClock()) runs in real time.
inline bool IsRealTime(const Clock* clock) {
  return clock == nullptr || clock->real_time();
}

// Virtual time, starting at 0: sleeping moves it to the deadline; its owner
// may also advance it, from any thread.
class VirtualClock final : public Clock {
 public:
  std::int64_t Now() const override { return now_.load(); }
  void SleepUntil(std::int64_t deadline) override;
  bool real_time() const override { return false; }
  // Moves the clock `nanoseconds` (>= 0) forward.
  void Advance(std::int64_t nanoseconds) { now_.fetch_add(nanoseconds); }
  // Paces the sleeps: virtual time moves at most `factor` times as fast
  // as the wall's, so that an operator can watch a run (0, the default:
  // as fast as the CPU allows). What the clock reads is unchanged: a run
  // is the same paced or not. After the loop sat idle (between runs) or a
  // jump (Advance), the pace starts afresh rather than race or wait to
  // catch up. For one sleeping thread (the loop); set before it runs.
  void set_pace(double factor) { pace_ = factor > 0 ? factor : 0; }
  double pace() const { return pace_; }

 private:
  void Pace(std::int64_t deadline);

  std::atomic<std::int64_t> now_{0};
  double pace_ = 0;
  std::int64_t wall_anchor_ = -1;  // [ns, CLOCK_MONOTONIC]
  std::int64_t virtual_anchor_ = 0;
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_RUNTIME_CLOCK_H_
