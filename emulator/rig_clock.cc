#include "emulator/rig_clock.h"

#include "rt_core/runtime/cycle_timer.h"

namespace kcrig {

double MonotonicRigClock::Now() const {
  return static_cast<double>(MonotonicNanoseconds()) * 1e-9;
}

}  // namespace kcrig
