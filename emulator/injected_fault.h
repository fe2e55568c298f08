// Faults the software-in-the-loop rig injects at chosen cycles of a run, so
// that the safety chain's reactions are tested deterministically, without
// real time and without a flaky host. Written in the --effect syntax:
// "KIND:at=CYCLE[,key=value]".
#ifndef KCRIG_EMULATOR_INJECTED_FAULT_H_
#define KCRIG_EMULATOR_INJECTED_FAULT_H_

#include <cstdint>
#include <string>
#include <string_view>

#include "base/status.h"

namespace kcrig {

struct InjectedFault {
  enum class Kind {
    kLate,     // the reply comes `delay` seconds late (the cycle overruns)
    kStale,    // the rig answers without a new sample for `cycles` reads
    kLost,     // the rig takes the sample, but the reply is lost
    kCorrupt,  // the reply arrives garbled: counter and x out of all range
    kSilent,   // the rig stops answering, for good
    kStuck,    // `channel` keeps the value it had at `at`, for good
    kNan,      // `channel` reads NaN once
    kForeign,  // another master's command reaches the rig (a front end
               // that does not enforce ownership), then it falls silent
    kEstop,    // the rig's own emergency stop: it faults and ramps down
  };
  Kind kind = Kind::kLost;
  // The loop's read at which it happens, from 0 (the cycle, when no cycle
  // before it was skipped).
  std::int64_t at = 0;
  double delay = 0;  // kLate [s]
  int cycles = 1;    // kStale
  // kStuck, kNan: 0..5 the six channels (x, y, z, toe, camber, caster),
  // 6..8 the load cell (Fx, Fy, Fz).
  int channel = 0;
  std::string text;  // as given, for the run's record
};

// Parses "late:at=1500,delay=0.03", "stale:at=1500,cycles=30",
// "lost:at=1500", "corrupt:at=1500", "silent:at=1500",
// "stuck:at=1500,channel=z", "nan:at=1500,channel=Fx", "foreign:at=1500",
// "estop:at=1500". One-line errors
// that name the item.
Status ParseInjectedFault(std::string_view text, InjectedFault* fault);

}  // namespace kcrig

#endif  // KCRIG_EMULATOR_INJECTED_FAULT_H_
