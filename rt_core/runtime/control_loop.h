// The fixed-step real-time loop. Every period: read the rig's newest sample,
// compute the excitation and one semi-implicit Euler step of the model (a live
// prediction driven by the measured force), check safety, write the command,
// push a CycleRecord into the log ring. Everything the cycle needs is
// allocated in the constructor; Cycle() allocates nothing, takes no lock and
// blocks only inside the transport's bounded read()/write().
#ifndef KCRIG_RT_CORE_RUNTIME_CONTROL_LOOP_H_
#define KCRIG_RT_CORE_RUNTIME_CONTROL_LOOP_H_

#include <array>
#include <atomic>
#include <cstdint>

#include "base/spsc_ring.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/suspension_model.h"
#include "rt_core/runtime/clock.h"
#include "rt_core/runtime/cycle_timer.h"
#include "rt_core/runtime/rig_interface.h"
#include "rt_core/runtime/safety.h"
#include "rt_core/runtime/timing_statistics.h"

namespace kcrig {

// What the logger receives per cycle. Plain arrays: trivially copyable.
struct CycleRecord {
  std::int64_t cycle = 0;
  std::uint32_t rig_sample = 0;
  std::uint16_t rig_status = 0;
  std::uint16_t rig_fault = 0;
  bool fresh = false;  // a new sample arrived this cycle
  RunPhase phase = RunPhase::kTare;
  SafetyState safety = SafetyState::kNormal;
  // The latched trip (kNone while normal) and its channel, so that a live
  // display names the cause the moment it happens.
  TripCause cause = TripCause::kNone;
  std::int8_t trip_channel = -1;
  std::uint8_t stop_signal = 0;  // for kSignal: SIGINT, SIGTERM
  // How late the machine woke this cycle [ns, saturated], and the loop's
  // overruns so far: timing as the run goes, for a live display.
  std::int32_t wakeup_latency_ns = 0;
  std::int64_t overruns = 0;
  double force[3] = {};      // load cell [N]
  double y[6] = {};          // measured [m, rad]
  double commanded[3] = {};  // set-points sent [N]
  double predicted[6] = {};  // model, relative to the rest pose [m, rad]
};

struct LoopOptions {
  double period = 1e-3;  // [s]
  // The experiment, and the phases around it.
  RampExcitation<double> excitation;
  RunProfileTimes profile;
  SafetyLimits safety;
  // Stop after this long [s] even if the profile goes on (0: the profile's
  // own duration). For timing checks.
  double max_duration = 0;
  // The time the cycles are paced on (null: CLOCK_MONOTONIC). On a
  // VirtualClock the loop sleeps no real time, its timing figures are the
  // CPU's cost of each phase, and it waits for a full log ring to drain
  // instead of dropping the record.
  Clock* clock = nullptr;
};

struct LoopResult {
  std::int64_t cycles = 0;       // cycles run
  std::int64_t fresh = 0;        // with a new sample
  std::int64_t stale = 0;        // the rig answered, no new sample
  std::int64_t read_errors = 0;  // timeout, exception, disconnect
  std::int64_t write_errors = 0;
  // Commands sent from the trip on (the ramp-down and the disable), and
  // those of them the transport could not deliver. After a foreign_master
  // trip none is sent (withheld: this controller's commands would fight
  // the other master's; the rig's own limits and watchdog stop it).
  std::int64_t commands_after_trip = 0;
  std::int64_t undelivered_after_trip = 0;
  std::int64_t withheld_after_trip = 0;
  // Samples the rig took for this controller's requests that never reached
  // it (gaps in the rig's counter), and steps of the counter that no such
  // loss explains (a restarted rig, a garbled counter).
  std::int64_t lost_rig_samples = 0;
  std::int64_t rig_sample_jumps = 0;
  std::int64_t overruns = 0;  // cycles that ran past a deadline
  std::int64_t skipped_cycles = 0;
  // Of skipped_cycles: the loop woke after them (the machine did not run
  // it), not lost to the cycle's own work or transport.
  std::int64_t skipped_by_late_wakeup = 0;
  std::uint64_t dropped_records = 0;  // ring full (logger behind)
  std::int64_t limited_commands = 0;
  TripCause cause = TripCause::kNone;
  std::int64_t trip_cycle = -1;
  int trip_channel = -1;             // for limit and error-detector trips
  int signal = 0;                    // for kSignal
  std::uint16_t rig_fault_code = 0;  // for kRigFault: what the rig reported
  Vec6<double> rest_pose = Vec6<double>::Zero();
};

// Per-phase timing of the cycles, in ns.
struct LoopTiming {
  TimingStatistics wakeup, read, compute, write, cycle;
};

class ControlLoop {
 public:
  // `model` is the prediction model (nominal parameters); `rig` may be null
  // (timing checks without a transport: the model runs on the command).
  ControlLoop(const SuspensionParameters<double>& model,
              const LoopOptions& options, RigInterface* rig,
              SpscRing<CycleRecord>* ring, const std::atomic<int>* stop_signal);

  // The loop trips (log_write_error) once *failed is true: a record of the
  // run (its log, a CAN run's bus log) can no longer be written. At most
  // kMaxLogFailures; optional; before Run.
  static constexpr int kMaxLogFailures = 2;
  void add_log_failure(const std::atomic<bool>* failed) {
    if (failed != nullptr && log_failures_ < kMaxLogFailures) {
      log_failed_[log_failures_++] = failed;
    }
  }

  // Runs the experiment to its end or to a trip with its ramp-down, sleeping
  // on absolute deadlines. The rig must be activated.
  LoopResult Run();

  // The cycle body, for Run() and for tests that step without sleeping;
  // `skipped` cycles were lost to an overrun just before this one. Returns
  // false once the run is over (profile done, or disabled after a trip).
  bool Cycle(std::int64_t cycle, std::int64_t skipped = 0);

  const LoopResult& result() const { return result_; }
  const LoopTiming& timing() const { return timing_; }

 private:
  // The cycle's work after the sample is read, in its stages: safety on
  // what was measured and on the events since the last cycle, the command
  // through the safety limits, the live prediction, the log row.
  void Compute(std::int64_t cycle, std::int64_t skipped, bool fresh,
               CycleRecord* record);
  void CheckMeasurement(std::int64_t cycle, RunPhase phase);
  void CheckEvents(std::int64_t cycle, std::int64_t skipped, bool fresh);
  Vec3<double> Command(std::int64_t cycle, double t, RunPhase phase);
  void Predict(bool fresh, const Vec3<double>& command, std::int64_t skipped);
  void Record(std::int64_t cycle, bool fresh, RunPhase phase,
              const Vec3<double>& command, CycleRecord* record) const;
  // A sample with a non-finite value: replaced by the last good one.
  bool Valid(const RigMeasurement& m) const;
  void CountSampleGap(std::uint32_t step, std::int64_t cycles);

  SuspensionModel<double> model_;
  LoopOptions options_;
  RigInterface* rig_;
  SpscRing<CycleRecord>* ring_;
  const std::atomic<int>* stop_signal_;
  bool virtual_time_;  // paced by a virtual clock
  std::array<const std::atomic<bool>*, kMaxLogFailures> log_failed_{};
  int log_failures_ = 0;
  RunProfile profile_;
  SafetyMonitor safety_;
  ModelState<double> state_;
  RigMeasurement measurement_;
  RigMeasurement last_good_;
  bool invalid_sample_ = false;
  bool transport_fault_ = false;    // the rig transport reported kFault
  bool foreign_master_ = false;     // the rig transport reported kForeign
  bool withhold_commands_ = false;  // another master seen: send nothing more
  RigCommand command_;
  Vec3<double> direction_;
  Vec6<double> tare_sum_ = Vec6<double>::Zero();
  int tare_count_ = 0;
  bool have_sample_ = false;
  std::int64_t last_fresh_cycle_ = 0;
  std::int64_t end_cycle_ = 0;
  LoopResult result_;
  LoopTiming timing_;
  // The current wake-up's latency and the overruns before it (set by Run),
  // for the cycle's record.
  std::int64_t wakeup_latency_ = 0;
  std::int64_t overruns_so_far_ = 0;
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_RUNTIME_CONTROL_LOOP_H_
