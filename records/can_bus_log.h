// The raw bus log of a CAN run: every frame kcrig sent or took in, in the
// order it did so, as `candump -l` lines (records/candump_log.h). The
// producer (the control loop's thread) only pushes into a lock-free ring;
// a writer thread formats and writes. The file is FILE.partial until
// Close() renames it, so a crash never leaves a can.log that looks whole.
#ifndef KCRIG_RECORDS_CAN_BUS_LOG_H_
#define KCRIG_RECORDS_CAN_BUS_LOG_H_

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <string>
#include <thread>
#include <utility>

#include "base/spsc_ring.h"
#include "base/status.h"
#include "io_drivers/can_frame.h"

namespace kcrig {

class CanBusLog : public CanFrameSink {
 public:
  CanBusLog() : ring_(kCapacity) {}
  // A sink for a CAN rig: Start opens `path`.
  explicit CanBusLog(std::string path)
      : ring_(kCapacity), path_(std::move(path)) {}
  ~CanBusLog() override;
  CanBusLog(const CanBusLog&) = delete;
  CanBusLog& operator=(const CanBusLog&) = delete;

  // Starts writing `path`.partial, naming frames' interface `interface`.
  Status Open(const std::string& path, const std::string& interface);
  bool is_open() const { return file_ != nullptr; }
  Status Start(const std::string& interface) override {
    return Open(path_, interface);
  }

  // From one producer thread; no allocation, no I/O. A full ring drops the
  // frame (counted).
  void Push(const TimedCanFrame& frame) override {
    if (file_ != nullptr) ring_.Push(frame);
  }

  // Writes what is left, renames `path`.partial to `path`.
  Status Close() override;
  // Stops and removes `path`.partial (nothing worth keeping was logged).
  void Discard() override;

  std::uint64_t dropped() const override { return ring_.dropped(); }
  std::int64_t written() const override { return written_.load(); }

 private:
  static constexpr std::size_t kCapacity = 1 << 16;
  void Drain();
  // Stops the writer and closes the file; false when writing failed.
  bool Stop();

  SpscRing<TimedCanFrame> ring_;
  std::string path_, interface_;
  std::FILE* file_ = nullptr;
  std::thread writer_;
  std::atomic<bool> stop_{false};
  std::atomic<std::int64_t> written_{0};
  bool write_failed_ = false;
};

}  // namespace kcrig

#endif  // KCRIG_RECORDS_CAN_BUS_LOG_H_
