// The raw bus log of a CAN run: every frame kcrig sent or took in, in the
// order it did so, as `candump -l` lines (records/candump_log.h). The
// producer (the control loop's thread) only pushes into a lock-free ring;
// a writer thread (PeriodicWorker) formats and writes to a PartialFile,
// renamed into place by Close().
#ifndef KCRIG_RECORDS_CAN_BUS_LOG_H_
#define KCRIG_RECORDS_CAN_BUS_LOG_H_

#include <atomic>
#include <cstdint>
#include <string>
#include <utility>

#include "base/periodic_worker.h"
#include "base/spsc_ring.h"
#include "base/status.h"
#include "io_drivers/can_frame.h"
#include "records/partial_file.h"

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
  bool is_open() const { return file_.is_open(); }
  Status Start(const std::string& interface) override {
    return Open(path_, interface);
  }

  // From one producer thread; no allocation, no I/O. A full ring drops the
  // frame (counted).
  void Push(const TimedCanFrame& frame) override {
    if (file_.is_open()) ring_.Push(frame);
  }

  // Writes what is left, renames `path`.partial to `path`.
  Status Close() override;
  // Stops and removes `path`.partial (nothing worth keeping was logged).
  void Discard() override;

  std::uint64_t dropped() const override { return ring_.dropped(); }
  std::int64_t written() const override { return written_.load(); }
  // Set once a write failed (a full disk): the frames of that wake-up are
  // lost, the file ends on a whole line.
  const std::atomic<bool>* write_failed() const override {
    return &write_failed_;
  }
  // After Close: the partial file, the error and the frames kept ("" if
  // no write failed).
  std::string WriteFailure() const override;

 private:
  static constexpr std::size_t kCapacity = 1 << 16;
  void Drain();

  SpscRing<TimedCanFrame> ring_;
  std::string path_, interface_;
  PartialFile file_;
  std::string lines_;  // one wake-up's lines, the writer thread's
  PeriodicWorker writer_;
  std::atomic<std::int64_t> written_{0};
  std::atomic<bool> write_failed_{false};
};

}  // namespace kcrig

#endif  // KCRIG_RECORDS_CAN_BUS_LOG_H_
