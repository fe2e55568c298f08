// The hardware interface between the loop and a rig transport, after
// ros2_control's SystemInterface: a lifecycle (configure -> activate ->
// deactivate, and error) called outside the cycle, and read()/write() called
// inside it. read() and write() must return within a bounded time (the
// transport's response timeout), never allocate, never throw; a failure is a
// missed sample for the watchdog, not an exception. The loop never knows
// which transport it talks to (Modbus or SocketCAN).
#ifndef KCRIG_RT_CORE_RUNTIME_RIG_INTERFACE_H_
#define KCRIG_RT_CORE_RUNTIME_RIG_INTERFACE_H_

#include <atomic>
#include <cstdint>
#include <string>

#include "base/status.h"
#include "rt_core/model/rig_signals.h"

namespace kcrig {

enum class IoResult {
  kFresh,    // a new sample arrived (read) / the command was accepted (write)
  kStale,    // the transport answered, but nothing new (read only)
  kError,    // timeout, exception, disconnect: counted by the watchdog
  kFault,    // the transport itself failed (CAN bus-off, error-passive, tx
             // timeout): the loop trips at once
  kForeign,  // read only: the rig obeys another master (it reports another
             // session in control, or echoes a command this controller did
             // not send): the loop trips at once
};

class RigInterface {
 public:
  virtual ~RigInterface() = default;

  // Lifecycle, outside the cycle. Configure opens the link and checks that
  // the peer speaks the protocol; Activate takes control of the rig (one
  // master: refused when another session holds it) and enables the
  // actuator (zero force); Deactivate commands zero force, disables and
  // gives control back; OnError puts the transport in its safe state after
  // a fault (best effort).
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

  // A record the transport keeps of the run itself (a CAN run's bus log):
  // its write failing (a full disk) is a fault, as the run log's is. The
  // flag is set once a write failed, from any thread (the loop trips
  // log_write_error on it); null when the transport keeps no record.
  virtual const std::atomic<bool>* record_write_failed() const {
    return nullptr;
  }
  // After the loop: which file failed, why, and what it keeps ("" if none).
  virtual std::string RecordWriteFailure() const { return ""; }
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_RUNTIME_RIG_INTERFACE_H_
