// timing.json (kcrig run, kcrig timing-check, a rig campaign's iterations):
// the loop's measured timing per phase, its overruns and real-time set-up,
// and the budget it was held to. Written by the rig session (hil) and read
// back by the report: one format, its writer and reader side by side.
#ifndef KCRIG_RECORDS_TIMING_FILE_H_
#define KCRIG_RECORDS_TIMING_FILE_H_

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "base/status.h"

namespace kcrig {

struct TimingPhase {
  std::int64_t count = 0;
  double min_us = 0, mean_us = 0, p50_us = 0, p99_us = 0, p999_us = 0,
         max_us = 0;
  // Bins: lower edge [us] and count.
  std::vector<std::pair<double, std::int64_t>> histogram_us;
};

// kcrig timing-check --baseline: the machine's own wake-up latency at the
// same priority and period, without work (as cyclictest -m -i).
struct TimingBaseline {
  double duration_s = 0;
  bool sched_fifo = false;
  TimingPhase wakeup;  // without histogram
  double kcrig_to_baseline_p99 = 0;
};

struct TimingFile {
  double period_us = 0;
  std::int64_t cycles = 0, overruns = 0, skipped_cycles = 0,
               skipped_by_late_wakeup = 0, dropped_log_records = 0;
  // The real-time set-up obtained and one warning per step refused.
  bool sched_fifo = false, cpu_affinity = false, memory_locked = false,
       no_cpu_idle = false;
  std::vector<std::string> realtime_warnings;
  // The safety trip that ended the loop early ("tripped: watchdog (...)"),
  // "" when it ran to its end: timing measured up to a fault is not a pass.
  std::string trip;
  // The link over the whole run, its end included: reads that failed
  // (timeout, exception, lost link), writes that failed, reads that brought
  // no new sample, samples the rig took that never arrived, and the error
  // of the rig's release after the loop ("" when it was released).
  std::int64_t read_errors = 0, write_errors = 0, stale_samples = 0,
               lost_rig_samples = 0;
  std::string release_error;
  // By phase name: wakeup, read, compute, write, cycle.
  std::map<std::string, TimingPhase> phases;
  // The budget (rig.yaml timing_budget) and whether the run held it;
  // `budget_checked` false in a file without one.
  bool budget_checked = false;
  double compute_p999_fraction = 0, wakeup_p99_us = 0, cycle_p999_fraction = 0;
  double overrun_max_fraction = 0;
  bool within_budget = false;
  std::vector<std::string> violations;
  bool has_baseline = false;
  TimingBaseline baseline;
};

// The file's text ("kcrig timing 1").
std::string TimingFileToJson(const TimingFile& timing);

// Reads a timing.json; period_us and phases (each with its percentiles and
// histogram) are required, the rest optional. Errors name the file and the
// field.
Status ReadTimingFile(const std::string& path, TimingFile* timing);

}  // namespace kcrig

#endif  // KCRIG_RECORDS_TIMING_FILE_H_
