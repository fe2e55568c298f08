// The logger of a rig session. On its own thread it takes the loop's cycle
// records from the ring, gives every cycle an overrun skipped a row without
// a fresh sample (so that the log's time column stays uniform), streams the
// rows to run.csv.partial as they come (records/partial_file.h), and
// reports progress and overrun warnings. Finish writes
// the sidecar and renames the partial file to run.csv.
#ifndef KCRIG_HIL_INTERNAL_RUN_LOGGER_H_
#define KCRIG_HIL_INTERNAL_RUN_LOGGER_H_

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
    // How long the run may last [s]: up to 10 minutes of rows are reserved
    // up front, a longer run grows the log in the logger thread.
    double expected_duration = 0;
    // About every 0.25 s with the time of the newest record [s]. Optional.
    std::function<void(double)> on_progress;
    // At most once a second when cycles were skipped since the last call:
    // one line. Optional.
    std::function<void(const std::string&)> on_warning;
  };

  explicit RunLogger(Options options);
  ~RunLogger();
  RunLogger(const RunLogger&) = delete;
  RunLogger& operator=(const RunLogger&) = delete;

  // Creates run.csv.partial with the header of log()'s columns.
  Status Open();
  // Starts the thread that drains `ring` (which must outlive Stop).
  void Start(SpscRing<CycleRecord>* ring);
  // Drains what is left and joins the thread (the loop has ended).
  void Stop();
  // Closes and removes the partial file (the experiment never started).
  void Discard();
  // After Stop, with log().metadata filled: the sidecar, and the partial
  // file renamed to run.csv. Errors name the file (or `log_dir` when fewer
  // than two cycles were logged); the partial file stays on a write error.
  Status Finish(const std::string& log_dir);

  // The rows logged, and those filled in for skipped cycles.
  RunLog& log() { return log_; }
  std::int64_t filled_rows() const { return filled_rows_; }

 private:
  void Drain(SpscRing<CycleRecord>* ring);
  void Stream();
  void Report();

  Options options_;
  PartialFile partial_;
  RunLog log_;
  PeriodicWorker worker_;
  std::chrono::steady_clock::time_point last_progress_, last_warning_;
  std::int64_t next_cycle_ = 0;
  std::int64_t filled_rows_ = 0;
  std::int64_t skipped_since_warning_ = 0;
  size_t streamed_ = 0;  // rows already on disk
  std::string rows_;
};

}  // namespace kcrig

#endif  // KCRIG_HIL_INTERNAL_RUN_LOGGER_H_
