// The hardware interface between the loop and a rig transport, after
// ros2_control's SystemInterface: a lifecycle (configure -> activate ->
// deactivate, and error) called outside the cycle, and read()/write() called
// inside it. read() and write() must return within a bounded time (the
// transport's response timeout), never allocate, never throw; a failure is a
// missed sample for the watchdog, not an exception. The loop never knows
// which transport it talks to (Modbus or SocketCAN).
#ifndef KCRIG_RT_CORE_RUNTIME_RIG_INTERFACE_H_
#define KCRIG_RT_CORE_RUNTIME_RIG_INTERFACE_H_

#include <cstdint>
#include <string>

#include "base/status.h"
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

enum class IoResult {
  kFresh,  // a new sample arrived (read) / the command was accepted (write)
  kStale,  // the transport answered, but nothing new (read only)
  kError,  // timeout, exception, disconnect: counted by the watchdog
  kFault,  // the transport itself failed (CAN bus-off, error-passive, tx
           // timeout): the loop trips at once
};

class RigInterface {
 public:
  virtual ~RigInterface() = default;

  // Lifecycle, outside the cycle. Configure opens the link and checks that
  // the peer speaks the protocol; Activate enables the actuator (zero
  // force); Deactivate commands zero force and disables; OnError puts the
  // transport in its safe state after a fault (best effort).
  virtual Status Configure() = 0;
  virtual Status Activate() = 0;
  virtual Status Deactivate() = 0;
  virtual void OnError() = 0;

  // Inside the cycle: bounded time, no allocation.
  virtual IoResult Read(RigMeasurement* measurement) = 0;
  virtual IoResult Write(const RigCommand& command) = 0;

  // For logs and messages: "modbus-tcp://127.0.0.1:1502".
  virtual std::string Describe() const = 0;

  // The transport's own counters and faults as a JSON object, for run.json
  // ("transport" in the hil block), read after the loop.
  virtual std::string CountersJson() const = 0;
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_RUNTIME_RIG_INTERFACE_H_
