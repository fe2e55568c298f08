// The logger of a rig session. On its own thread it takes the loop's cycle
// records from the ring, gives every cycle an overrun skipped a row without
// a fresh sample (so that the log's time column stays uniform), streams the
// rows to run.csv.partial as they come (records/partial_file.h) and keeps
// only counters and the last row: its memory does not grow with the run.
// A row the disk refuses (full, or a file-size limit) raises
// write_failed() — the loop trips on it — and waits in a bounded buffer
// that is retried; the file always ends on a whole row. Room for the
// run's record (the sidecar, timing.json) is reserved on the log's disk at
// Open (run.csv.reserve) and handed back at Finish, so a full disk still
// gets the sidecar that says why. It reports progress and overrun
// warnings. Finish writes the sidecar and renames the partial file to
// run.csv.
#ifndef KCRIG_HIL_INTERNAL_RUN_LOGGER_H_
#define KCRIG_HIL_INTERNAL_RUN_LOGGER_H_

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "base/periodic_worker.h"
#include "base/spsc_ring.h"
#include "base/status.h"
#include "records/partial_file.h"
#include "records/run_log.h"
#include "rt_core/runtime/control_loop.h"

namespace kcrig {

class RunLogger {
 public:
  struct Options {
    double period = 1e-3;  // the loop's [s]
    // The log to write ("" = none: records are only drained).
    std::string csv_path;
    // About every 0.25 s with the time of the newest record [s]. Optional.
    std::function<void(double)> on_progress;
    // At most once a second when cycles were skipped since the last call:
    // one line. Optional.
    std::function<void(const std::string&)> on_warning;
    // The loop's CPU when it is pinned to one (-1: not): the logger keeps
    // off it.
    int loop_cpu = -1;
    // Every record as it is taken from the ring (a live display). Optional.
    std::function<void(const CycleRecord&)> on_record;
  };

  explicit RunLogger(Options options);
  ~RunLogger();
  RunLogger(const RunLogger&) = delete;
  RunLogger& operator=(const RunLogger&) = delete;

  // Creates run.csv.partial with the header of log()'s columns and reserves
  // kRecordReserveBytes beside it; an error when the disk has not that room.
  Status Open();
  // Starts the thread that drains `ring` (which must outlive Stop).
  void Start(SpscRing<CycleRecord>* ring);
  // Drains what is left and joins the thread (the loop has ended).
  void Stop();
  // Closes and removes the partial file (the experiment never started).
  void Discard();
  // After Stop, with log().metadata filled: frees the reserve for the
  // run's record (the caller writes timing.json next), the sidecar, and the
  // partial
  // file renamed to run.csv. Errors name the file (or `log_dir` when fewer
  // than two cycles were logged); after a write failure the partial file
  // stays, ending on a whole row, with the sidecar of its rows beside it.
  Status Finish(const std::string& log_dir);

  // The log's columns and metadata (no samples: they are on disk).
  RunLog& log() { return log_; }
  // Set once a write failed; never cleared. For the loop, any thread.
  const std::atomic<bool>& write_failed() const { return write_failed_; }
  // After Stop: why the write failed ("" if none) and what was lost.
  std::string WriteFailure() const;
  // Rows logged (those on disk, plus those that never reached it), those
  // filled in for skipped cycles, those without a fresh sample.
  std::int64_t rows() const { return rows_; }
  std::int64_t filled_rows() const { return filled_rows_; }
  std::int64_t rows_without_fresh_sample() const { return not_fresh_; }

 private:
  void Drain(SpscRing<CycleRecord>* ring);
  void Append(const LogSample& sample);
  void Stream();
  void Report();

  // Text of rows the disk refused, kept for a retry: a few minutes of rows
  // at 1 kHz; beyond it rows are counted as lost.
  static constexpr size_t kMaxPendingBytes = 32u << 20;
  // The sidecar (a few KiB) and timing.json (its histograms, ~120 KiB).
  static constexpr long kRecordReserveBytes = 512L << 10;

  Status Reserve();
  void ReleaseReserve();

  Options options_;
  PartialFile partial_;
  RunLog log_;
  PeriodicWorker worker_;
  std::chrono::steady_clock::time_point last_progress_, last_warning_;
  std::int64_t next_cycle_ = 0;
  std::int64_t rows_ = 0;
  std::int64_t filled_rows_ = 0;
  std::int64_t not_fresh_ = 0;
  std::int64_t skipped_since_warning_ = 0;
  LogSample last_;       // the newest row, repeated for skipped cycles
  std::string pending_;  // rows not yet on disk, whole
  std::int64_t pending_rows_ = 0;
  std::int64_t written_rows_ = 0;
  std::int64_t lost_rows_ = 0;  // beyond kMaxPendingBytes
  std::atomic<bool> write_failed_{false};
  std::string reserve_path_;  // while the reserve exists
};

}  // namespace kcrig

#endif  // KCRIG_HIL_INTERNAL_RUN_LOGGER_H_
