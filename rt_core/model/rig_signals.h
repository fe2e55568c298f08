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
