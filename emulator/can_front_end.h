// The emulator's CAN node: the rig side of config/kc_rig.dbc on a SocketCAN
// interface for a RigEmulator. KC_Session claims and releases the rig for
// a session (one master: rig_ownership.h). Each KC_Command of the owner's
// session is applied and answered at once with one sample in four frames
// (the rig samples on command, so the controller sees one new sample per
// cycle); any other session's is refused, counted and left unanswered.
// KC_Setup sets the acting height; KC_Heartbeat (with the owner, and
// whether anything was refused since the last one) goes out at 10 Hz and
// on every status change. The plant advances to the clock's time between
// frames (at least every millisecond). Malformed frames are counted and
// ignored.
#ifndef KCRIG_EMULATOR_CAN_FRONT_END_H_
#define KCRIG_EMULATOR_CAN_FRONT_END_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

#include "emulator/rig_emulator.h"
#include "rt_core/runtime/clock.h"

namespace kcrig {

struct CanNodeCounters {
  std::int64_t commands = 0, samples_sent = 0, heartbeats = 0, malformed = 0,
               send_failures = 0;
  std::int64_t refused = 0;  // KC_Command and KC_Session of non-owners
};

// Opens `interface`, calls `on_ready` once the node listens, serves until
// *stop is non-zero.
Status ServeCan(RigEmulator* rig, const Clock& clock,
                const std::string& dbc_file, const std::string& interface,
                const std::atomic<int>& stop,
                const std::function<void()>& on_ready,
                CanNodeCounters* counters);

}  // namespace kcrig

#endif  // KCRIG_EMULATOR_CAN_FRONT_END_H_
