// What a rig measures and is commanded, in SI units: the values the loop,
// the transports, the CAN codec and the emulator exchange. Data only, so
// that decoding a log never needs the real-time runtime.
#ifndef KCRIG_RT_CORE_MODEL_RIG_SIGNALS_H_
#define KCRIG_RT_CORE_MODEL_RIG_SIGNALS_H_

#include <cstdint>

#include "rt_core/model/rotation.h"

namespace kcrig {

// Rig status bits, as the rig reports them (Modbus input register `status`,
// CAN heartbeat).
enum RigStatusBit : std::uint16_t {
  kRigEnabled = 1u << 0,   // actuator under force control
  kRigFault = 1u << 1,     // the rig tripped on its own (see fault code)
  kRigLimit = 1u << 2,     // the rig clamped a set-point at its limit
  kRigWatchdog = 1u << 3,  // the rig saw no command within its timeout
};

// The rig's fault codes (Modbus input register `fault_code`, CAN
// KC_Heartbeat FaultCode): why a rig faulted itself and ramped down.
enum RigFaultCode : std::uint16_t {
  kFaultNone = 0,
  kFaultTravel = 1,          // its own travel limit
  kFaultCommandTimeout = 2,  // enabled, no command within its timeout
  kFaultDiverged = 3,        // its plant left the finite range
  kFaultOwnerLost = 4,       // the owner's connection closed while enabled
  kFaultEmergencyStop = 5,   // its own emergency stop was pressed
};

// What a fault code means, for messages ("" for none, "an unknown fault
// code" for a rig's own codes beyond these).
inline const char* RigFaultMeaning(std::uint16_t code) {
  switch (code) {
    case kFaultNone:
      return "";
    case kFaultTravel:
      return "its own travel limit";
    case kFaultCommandTimeout:
      return "its command watchdog: no command reached it within its "
             "command timeout (a stall of the link or of this controller)";
    case kFaultDiverged:
      return "its plant diverged";
    case kFaultOwnerLost:
      return "the owner's connection closed while it was enabled";
    case kFaultEmergencyStop:
      return "its emergency stop";
  }
  return "a fault code kcrig does not know";
}

// The owner register's value for a client that is not the owner while the
// rig is claimed: a session token never handed out.
inline constexpr std::uint16_t kOwnerHidden = 0xffff;

// One sample of the rig's sensors.
struct RigMeasurement {
  std::uint32_t sample = 0;                   // the rig's sample counter
  Vec3<double> force = Vec3<double>::Zero();  // load cell [N]
  Vec6<double> y = Vec6<double>::Zero();      // x, y, z [m], angles [rad]
  std::uint16_t status = 0;                   // RigStatusBit
  std::uint16_t fault_code = 0;               // the rig's, 0 = none
};

// One command to the rig.
struct RigCommand {
  Vec3<double> force = Vec3<double>::Zero();  // set-points [N]
  // Height of the force's acting point above the wheel centre [m] (the
  // rig's fixture; with moment actuators, M = r x F at the wheel centre).
  double z_a = 0;
  bool enable = false;
  // The loop's cycle index mod 2^16: a gap is cycles skipped by overruns.
  std::uint16_t sequence = 0;
  // For transports that tell the rig (and their logs) where the run is:
  // 0 outside the loop (lifecycle), else 1 + RunPhase; and SafetyState.
  std::uint8_t phase = 0;
  std::uint8_t safety = 0;
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_RIG_SIGNALS_H_
