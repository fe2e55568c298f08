// A Linux SocketCAN raw socket (PF_CAN, CAN_RAW), non-blocking: receive
// filters, error frames opted in, kernel receive time stamps. The only
// place that touches the kernel's CAN structures; everything above sees
// CanFrame.
#ifndef KCRIG_IO_DRIVERS_SOCKET_CAN_H_
#define KCRIG_IO_DRIVERS_SOCKET_CAN_H_

#include <cstdint>
#include <string>
#include <vector>

#include "base/status.h"
#include "io_drivers/can_frame.h"

namespace kcrig {

struct CanFilter {
  std::uint32_t id = 0;    // 11-bit
  std::uint32_t mask = 0;  // bits of id that must match
};

struct CanSocketOptions {
  std::string interface;  // "vcan0", "can0"
  // Standard-id frames that match any filter are received; empty: all
  // frames.
  std::vector<CanFilter> filters;
  // Receive error frames (bus-off, controller state, tx timeout, protocol
  // errors) as CanFrame::error.
  bool error_frames = true;
};

// The wall-clock time [us since the epoch], the clock of candump's stamps.
std::int64_t WallClockMicros();

class CanSocket {
 public:
  CanSocket() = default;
  ~CanSocket();
  CanSocket(const CanSocket&) = delete;
  CanSocket& operator=(const CanSocket&) = delete;

  Status Open(const CanSocketOptions& options);
  void Close();
  bool is_open() const { return fd_ >= 0; }

  enum class SendResult {
    kSent,
    kQueueFull,  // ENOBUFS / EAGAIN: the interface's transmit queue is full
    kError,      // the interface is down or gone (errno in *error)
  };
  // Non-blocking; no allocation.
  SendResult Send(const CanFrame& frame, int* error);

  // Non-blocking: true when a frame was read, with the kernel's receive
  // time stamp; false when none is waiting (or on an error, in *error,
  // else 0). No allocation.
  bool Receive(TimedCanFrame* frame, int* error);

  // Waits until a frame can be read or `timeout` [s] passed.
  bool WaitReadable(double timeout);

 private:
  int fd_ = -1;
};

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_SOCKET_CAN_H_
