// The clock a front end advances the software rig by. `kcrig emulate` runs
// on the monotonic clock, in real time, as a rig does; a ManualRigClock
// moves only when its owner advances it, so that the rig's plant, watchdog
// and ownership timeouts follow the caller's time and no host (a loaded
// machine, code under the sanitizers) can make the plant fall behind.
#ifndef KCRIG_EMULATOR_RIG_CLOCK_H_
#define KCRIG_EMULATOR_RIG_CLOCK_H_

#include <atomic>

namespace kcrig {

// Where a front end reads the rig's time.
class RigClock {
 public:
  virtual ~RigClock() = default;
  // The current time [s], monotonic, any origin.
  virtual double Now() const = 0;
};

// Real time: CLOCK_MONOTONIC.
class MonotonicRigClock final : public RigClock {
 public:
  double Now() const override;
};

// Virtual time, advanced by its owner from any thread; starts at 0.
class ManualRigClock final : public RigClock {
 public:
  double Now() const override { return now_.load(); }
  // Moves the clock `seconds` (≥ 0) forward.
  void Advance(double seconds) { now_.fetch_add(seconds); }

 private:
  std::atomic<double> now_{0.0};
};

}  // namespace kcrig

#endif  // KCRIG_EMULATOR_RIG_CLOCK_H_
