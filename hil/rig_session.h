// One HIL experiment through a rig transport, end to end: lifecycle
// (configure, activate, deactivate / error), real-time set-up, the control
// loop on the calling thread, a logger thread that drains the loop's ring,
// and the outputs run.csv + run.json (written together) and timing.json,
// also after a trip or a signal. Used by `kcrig run`, `kcrig campaign`,
// `kcrig timing-check` and `kcrig validate` (its blind cases on the SIL
// rig).
#ifndef KCRIG_HIL_RIG_SESSION_H_
#define KCRIG_HIL_RIG_SESSION_H_

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hil/rig_config.h"
#include "records/run_log.h"
#include "records/timing_file.h"
#include "rt_core/model/model_config.h"
#include "rt_core/runtime/clock.h"
#include "rt_core/runtime/control_loop.h"
#include "rt_core/runtime/realtime.h"
#include "rt_core/runtime/rig_interface.h"

namespace kcrig {

class RunMonitor;

struct RigSessionOptions {
  // The experiment; the run profile's phases come from rig.yaml.
  RampExcitation<double> excitation;
  // Output directory for run.csv, run.json, timing.json ("" = none).
  std::string log_dir;
  // Stop after this long [s] (0 = the whole run profile).
  double max_duration = 0;
  // Set by the caller's signal handler: SIGINT/SIGTERM ramp down.
  const std::atomic<int>* stop_signal = nullptr;
  // The time the loop runs on (null: CLOCK_MONOTONIC, in real time with
  // rig.yaml's real-time set-up). The software-in-the-loop rig's virtual
  // clock needs no set-up: the loop then never sleeps.
  Clock* clock = nullptr;
  // A software rig's truth (synthetic, noise_added, seed, truth_parameters,
  // truth_effects), recorded in the sidecar as SimulateRun's logs record
  // theirs. Optional.
  const RunMetadata* truth = nullptr;
  // Called from the logger thread about every 0.25 s with the run time [s]
  // and the phase, for progress lines. Optional.
  std::function<void(double, RunPhase)> on_progress;
  // Called from the logger thread, at most once a second, when cycles were
  // skipped by overruns since the last call: one line. Optional.
  std::function<void(const std::string&)> on_warning;
  // A live display of the run (the operator console), fed from the logger
  // thread. Optional; must outlive the call.
  RunMonitor* monitor = nullptr;
};

struct RigSessionResult {
  LoopResult loop;
  RealtimeReport realtime;
  std::int64_t logged_rows = 0;  // rows in run.csv
  std::int64_t filled_rows = 0;  // of them, cycles skipped by overruns
  bool completed = false;        // the run profile ran to its end
  std::string trip_message;      // one line when tripped
  std::string release_error;     // the rig's release after the loop failed
  TimingFile timing;             // what timing.json holds
};

// What a live display sees of a rig session: told what runs before the
// loop starts, given every cycle record from the logger thread (the log
// ring's consumer, never the cycle itself), told the outcome once the
// run's files are written (or why it could not start). Calls must return
// quickly and never throw: a slow monitor delays the log, not the loop.
class RunMonitor {
 public:
  struct Run {
    std::string rig;  // as the log's sidecar names it
    RampExcitation<double> excitation;
    SafetyLimits limits;
    double period = 1e-3;   // [s]
    double duration = 0;    // the whole run profile [s]
    bool real_time = true;  // false: on the SIL rig's virtual clock
    std::string log_dir;
  };
  virtual ~RunMonitor() = default;
  virtual void RunStarted(const Run& run) = 0;
  virtual void CycleLogged(const CycleRecord& record) = 0;
  // `outcome`: "completed", the trip message or the error.
  virtual void RunEnded(bool completed, const std::string& outcome,
                        const LoopResult& loop) = 0;
};

// A trip's cause as a record shows it the moment it latches ("watchdog (no
// fresh measurement ...) at t = 1.234 s"); what reached the rig after it
// is known only at the run's end (RigSessionResult::trip_message).
std::string LiveTripCause(const CycleRecord& record, double period);

// The excitation against the safety limits of rig.yaml: finite direction,
// height within +-2 m, 0 <= Fmax <= force_max, 0 < tf <= 3600 s, and every
// phase of the run within force_rate_max. One-line errors.
Status ValidateRunRequest(const RigConfig& rig_config,
                          const RigSessionOptions& options);

// `rig` may be null: the loop runs the model alone (timing checks). Returns
// an error only when the experiment could not start or its outputs could
// not be written; a trip is a result (completed = false, trip_message).
Status RunRigSession(const KcrigConfig& config, const RigConfig& rig_config,
                     RigInterface* rig, const RigSessionOptions& options,
                     RigSessionResult* result);

// timing.json's content: per phase (wakeup, read, compute, write, cycle)
// min, mean, p50, p99, p99.9, max [us] and a histogram; overruns; the
// real-time set-up and its warnings; the budget and whether it held.
TimingFile MakeTimingFile(const LoopTiming& timing, const LoopResult& loop,
                          const RealtimeReport& realtime, double period,
                          const TimingBudget& budget, bool with_transport);

// Whether the timing and the loop's overruns are within `budget`;
// `violations` gets one line per violated item.
bool WithinBudget(const LoopTiming& timing, const LoopResult& loop,
                  double period, const TimingBudget& budget,
                  bool with_transport, std::vector<std::string>* violations);

}  // namespace kcrig

#endif  // KCRIG_HIL_RIG_SESSION_H_
