// A classic CAN frame as kcrig's codec, logs and transports see it: plain
// data, independent of the kernel's struct can_frame (so the offline log
// reader and the fuzzers build anywhere).
#ifndef KCRIG_IO_DRIVERS_CAN_FRAME_H_
#define KCRIG_IO_DRIVERS_CAN_FRAME_H_

#include <atomic>
#include <cstdint>
#include <string>

#include "base/status.h"

namespace kcrig {

struct CanFrame {
  std::uint32_t id = 0;   // 11 or 29 bits, no flags; error frames: the class
  bool extended = false;  // 29-bit id
  bool remote = false;    // RTR
  bool error = false;     // an error frame (id = CAN_ERR_* class bits)
  std::uint8_t dlc = 0;   // 0..8
  std::uint8_t data[8] = {};
};

// A frame with its time stamp [us since the epoch] (the kernel's receive
// time, or the send time for frames kcrig sent).
struct TimedCanFrame {
  std::int64_t time_us = 0;
  CanFrame frame;
};

// Where a CAN rig hands every frame it sent or took in. Transports do no
// file I/O of their own: hil/ gives the rig records' can.log writer.
class CanFrameSink {
 public:
  virtual ~CanFrameSink() = default;
  // Before the first frame, once the rig's transport is up (Configure);
  // `interface` names the frames' bus.
  virtual Status Start(const std::string& interface) = 0;
  // From the cycle's thread: no allocation, no I/O.
  virtual void Push(const TimedCanFrame& frame) = 0;
  // Keeps what was pushed (an experiment ran).
  virtual Status Close() = 0;
  // Drops it (the rig was never activated).
  virtual void Discard() = 0;
  virtual std::int64_t written() const = 0;
  virtual std::uint64_t dropped() const = 0;
  // Set once a write failed (RigInterface::record_write_failed), and why.
  virtual const std::atomic<bool>* write_failed() const { return nullptr; }
  virtual std::string WriteFailure() const { return ""; }
};

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_CAN_FRAME_H_
