#include "hil/rig_session.h"

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "base/atomic_files.h"
#include "hil/internal/run_logger.h"
#include "nlohmann/json.hpp"
#include "records/run_log.h"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

constexpr std::size_t kRingCapacity = 1 << 16;  // 65 s at 1 kHz

TimingPhase Phase(const TimingStatistics& s) {
  TimingPhase p;
  p.count = s.count();
  p.min_us = s.min() * 1e-3;
  p.mean_us = s.mean() * 1e-3;
  p.p50_us = s.Percentile(0.5) * 1e-3;
  p.p99_us = s.Percentile(0.99) * 1e-3;
  p.p999_us = s.Percentile(0.999) * 1e-3;
  p.max_us = s.max() * 1e-3;
  for (const auto& [lower, count] : s.Histogram()) {
    p.histogram_us.emplace_back(lower * 1e-3, count);
  }
  return p;
}

std::string Channel(int k) {
  return k >= 0 && k < kNumChannels ? kChannelNames[k] : "?";
}

// `detail`: what the transport reported (kTransportFault, kForeignMaster)
// or the logger (kLogWrite).
std::string TripCauseText(const LoopResult& loop, double period,
                          const std::string& detail) {
  if (loop.cause == TripCause::kNone) return "";
  std::string what = TripCauseName(loop.cause);
  switch (loop.cause) {
    case TripCause::kTravelLimit:
    case TripCause::kAngleLimit:
      what += " (" + Channel(loop.trip_channel) + " beyond its limit)";
      break;
    case TripCause::kModelError:
      what += " (" + Channel(loop.trip_channel) +
              ": measured - model prediction beyond the limit)";
      break;
    case TripCause::kWatchdog:
      what += " (no fresh measurement for the configured number of cycles)";
      break;
    case TripCause::kRigFault:
      what += loop.rig_fault_code == kFaultNone
                  ? std::string(
                        " (the rig stopped being enabled: local mode "
                        "or its emergency stop)")
                  : " (the rig reported fault " +
                        std::to_string(loop.rig_fault_code) + ": " +
                        RigFaultMeaning(loop.rig_fault_code) + ")";
      break;
    case TripCause::kInvalidMeasurement:
      what += " (the rig sent a non-finite value)";
      break;
    case TripCause::kTransportFault:
    case TripCause::kForeignMaster:
    case TripCause::kLogWrite:
      what += " (" + detail + ")";
      break;
    case TripCause::kForceTracking:
      what += std::string(" (F") + "xyz"[std::clamp(loop.trip_channel, 0, 2)] +
              ": the load cell does not follow the command; another master "
              "or a failed actuator?)";
      break;
    case TripCause::kSignal:
      what += std::string(" (") +
              (loop.signal == 15  ? "SIGTERM"
               : loop.signal == 2 ? "SIGINT"
                                  : "signal") +
              ")";
      break;
    default:
      break;
  }
  char at[64];
  std::snprintf(at, sizeof(at), " at t = %.3f s",
                static_cast<double>(loop.trip_cycle) * period);
  return what + at;
}

std::string TripMessage(const LoopResult& loop, double period,
                        const std::string& detail) {
  if (loop.cause == TripCause::kNone) return "";
  // Say what reached the rig, not what was meant to.
  std::string outcome = "; force ramped to zero and disabled";
  if (loop.withheld_after_trip > 0) {
    outcome =
        "; this controller's loop sent no more commands (they would fight "
        "the other master's): the rig's own limits and command watchdog "
        "must stop it";
  } else if (loop.commands_after_trip > 0 &&
             loop.undelivered_after_trip == loop.commands_after_trip) {
    outcome =
        "; the force command ramped to zero, but none of it reached the rig "
        "(its own watchdog must stop it)";
  } else if (loop.undelivered_after_trip > 0) {
    outcome += " (" + std::to_string(loop.undelivered_after_trip) + " of " +
               std::to_string(loop.commands_after_trip) +
               " ramp-down commands did not reach the rig)";
  }
  return "tripped: " + TripCauseText(loop, period, detail) + outcome;
}

Status CreateLogDir(const std::string& log_dir) {
  if (log_dir.empty()) return Status::Ok();
  std::error_code error;
  std::filesystem::create_directories(log_dir, error);
  if (error || !std::filesystem::is_directory(log_dir)) {
    return Status::Error("--log-dir " + log_dir +
                         ": cannot create the directory");
  }
  return Status::Ok();
}

LoopOptions LoopOptionsFor(const RigConfig& rig_config,
                           const RigSessionOptions& options) {
  LoopOptions loop;
  loop.period = rig_config.period;
  loop.excitation = options.excitation;
  loop.profile = rig_config.profile;
  loop.safety = rig_config.safety;
  loop.max_duration = options.max_duration;
  loop.clock = options.clock;
  return loop;
}

RunLogger::Options LoggerOptionsFor(const RigConfig& rig_config,
                                    const RigSessionOptions& options,
                                    const RunProfile& profile) {
  RunLogger::Options logger;
  logger.period = rig_config.period;
  if (!options.log_dir.empty()) {
    logger.csv_path =
        (std::filesystem::path(options.log_dir) / "run.csv").string();
  }
  logger.on_warning = options.on_warning;
  if (IsRealTime(options.clock)) logger.loop_cpu = rig_config.realtime.cpu;
  if (options.monitor != nullptr) {
    logger.on_record = [monitor = options.monitor](const CycleRecord& r) {
      monitor->CycleLogged(r);
    };
  }
  if (options.on_progress) {
    logger.on_progress = [&options, profile](double t) {
      options.on_progress(t, profile.Phase(t));
    };
  }
  return logger;
}

// Real-time set-up first (mlockall faults every page in, which takes time),
// then enable the rig, whose command watchdog runs from then; after the
// loop, zero force and disabled whatever ended it (best effort when the
// link is gone: the rig's own watchdog then does it). On a virtual clock
// no set-up: the loop meets no deadline.
Status RunOnRig(const RealtimeOptions& realtime, bool real_time,
                RigInterface* rig, ControlLoop* loop,
                RigSessionResult* result) {
  if (real_time) result->realtime = SetUpRealtime(realtime);
  const Status activated = rig != nullptr ? rig->Activate() : Status::Ok();
  if (activated.ok()) result->loop = loop->Run();
  if (real_time) LeaveRealtime();
  if (rig != nullptr) {
    const Status released = rig->Deactivate();
    if (!released.ok()) {
      result->release_error = released.message();
      rig->OnError();
    }
  }
  return activated;
}

// The transport's counters and fault (an empty object without a rig).
nlohmann::ordered_json TransportCounters(const RigInterface* rig) {
  if (rig == nullptr) return nlohmann::ordered_json::object();
  nlohmann::ordered_json counters = nlohmann::ordered_json::parse(
      rig->CountersJson(), nullptr, /*allow_exceptions=*/false);
  return counters.is_discarded() ? nlohmann::ordered_json::object() : counters;
}

// run.json's "hil" block: the phases, the safety outcome, the loop's
// counters and the transport's.
std::string HilJson(const RigConfig& rig_config,
                    const RigSessionOptions& options, const RunProfile& profile,
                    const RigSessionResult& result,
                    std::int64_t rows_without_fresh_sample,
                    const nlohmann::ordered_json& transport) {
  const RunProfileTimes& p = rig_config.profile;
  const LoopResult& lr = result.loop;
  nlohmann::ordered_json hil;
  hil["profile_s"] = {{"tare", p.tare},
                      {"lead_in", p.lead_in},
                      {"settle", p.settle},
                      {"ramp", options.excitation.duration},
                      {"hold", options.excitation.hold},
                      {"return", options.excitation.return_duration},
                      {"ramp_down", p.ramp_down},
                      {"ramp_start", profile.ramp_start()}};
  hil["completed"] = result.completed;
  hil["safety"] = {{"tripped", !result.completed},
                   {"cause", TripCauseName(lr.cause)},
                   {"message", result.trip_message},
                   {"trip_time_s",
                    lr.trip_cycle >= 0
                        ? static_cast<double>(lr.trip_cycle) * rig_config.period
                        : -1.0},
                   {"limited_commands", lr.limited_commands}};
  hil["cycles"] = lr.cycles;
  hil["fresh_samples"] = lr.fresh;
  hil["stale_samples"] = lr.stale;
  hil["read_errors"] = lr.read_errors;
  hil["write_errors"] = lr.write_errors;
  hil["commands_after_trip"] = lr.commands_after_trip;
  hil["undelivered_after_trip"] = lr.undelivered_after_trip;
  hil["withheld_after_trip"] = lr.withheld_after_trip;
  hil["lost_rig_samples"] = lr.lost_rig_samples;
  hil["rig_sample_jumps"] = lr.rig_sample_jumps;
  hil["overruns"] = lr.overruns;
  hil["skipped_cycles"] = lr.skipped_cycles;
  hil["skipped_by_late_wakeup"] = lr.skipped_by_late_wakeup;
  hil["rows_without_fresh_sample"] = rows_without_fresh_sample;
  hil["dropped_log_records"] = lr.dropped_records;
  hil["rest_pose"] =
      std::vector<double>(lr.rest_pose.data(), lr.rest_pose.data() + 6);
  hil["realtime_warnings"] = result.realtime.warnings;
  hil["transport"] = transport;
  // The process's peak resident memory (locked, under mlockall): what the
  // rig PC must hold, the same for a run of seconds or of an hour. Null on
  // a virtual clock, whose run.json is the same for a seed on any machine.
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  hil["peak_memory_mib"] =
      IsRealTime(options.clock)
          ? nlohmann::ordered_json(static_cast<double>(usage.ru_maxrss) /
                                   1024.0)
          : nlohmann::ordered_json();
  return hil.dump();
}

}  // namespace

TimingFile MakeTimingFile(const LoopTiming& timing, const LoopResult& loop,
                          const RealtimeReport& realtime, double period,
                          const TimingBudget& budget, bool with_transport) {
  TimingFile t;
  t.period_us = period * 1e6;
  t.cycles = loop.cycles;
  t.overruns = loop.overruns;
  t.skipped_cycles = loop.skipped_cycles;
  t.skipped_by_late_wakeup = loop.skipped_by_late_wakeup;
  t.dropped_log_records = loop.dropped_records;
  t.read_errors = loop.read_errors;
  t.write_errors = loop.write_errors;
  t.stale_samples = loop.stale;
  t.lost_rig_samples = loop.lost_rig_samples;
  t.sched_fifo = realtime.fifo;
  t.cpu_affinity = realtime.affinity;
  t.memory_locked = realtime.locked;
  t.no_cpu_idle = realtime.no_cpu_idle;
  t.realtime_warnings = realtime.warnings;
  t.phases = {{"wakeup", Phase(timing.wakeup)},
              {"read", Phase(timing.read)},
              {"compute", Phase(timing.compute)},
              {"write", Phase(timing.write)},
              {"cycle", Phase(timing.cycle)}};
  t.budget_checked = true;
  t.compute_p999_fraction = budget.compute_p999_fraction;
  t.wakeup_p99_us = budget.wakeup_p99 * 1e6;
  t.cycle_p999_fraction = budget.cycle_p999_fraction;
  t.overrun_max_fraction = budget.overrun_max_fraction;
  t.within_budget =
      WithinBudget(timing, loop, period, budget, with_transport, &t.violations);
  return t;
}

bool WithinBudget(const LoopTiming& timing, const LoopResult& loop,
                  double period, const TimingBudget& budget,
                  bool with_transport, std::vector<std::string>* violations) {
  const double period_ns = period * 1e9;
  auto check = [&](const char* what, double value_ns, double limit_ns) {
    if (value_ns > limit_ns) {
      char line[160];
      std::snprintf(line, sizeof(line), "%s %.1f us > budget %.1f us", what,
                    value_ns * 1e-3, limit_ns * 1e-3);
      violations->push_back(line);
    }
  };
  check("compute p99.9", timing.compute.Percentile(0.999),
        budget.compute_p999_fraction * period_ns);
  check("wake-up latency p99", timing.wakeup.Percentile(0.99),
        budget.wakeup_p99 * 1e9);
  if (with_transport) {
    check("cycle p99.9", timing.cycle.Percentile(0.999),
          budget.cycle_p999_fraction * period_ns);
  }
  const double overrun_fraction =
      loop.cycles > 0 ? static_cast<double>(loop.overruns) / loop.cycles : 0.0;
  if (overrun_fraction > budget.overrun_max_fraction) {
    char line[160];
    std::snprintf(line, sizeof(line),
                  "overruns %lld of %lld cycles (%.2f %%) > budget %.2f %%",
                  static_cast<long long>(loop.overruns),
                  static_cast<long long>(loop.cycles), 100 * overrun_fraction,
                  100 * budget.overrun_max_fraction);
    violations->push_back(line);
  }
  return violations->empty();
}

Status ValidateRunRequest(const RigConfig& rig_config,
                          const RigSessionOptions& options) {
  const SafetyLimits& limits = rig_config.safety;
  const RunProfileTimes& p = rig_config.profile;
  const RampExcitation<double>& e = options.excitation;
  char text[200];
  if (!std::isfinite(e.phi)) return Status::Error("phi: must be finite");
  if (!(std::abs(e.z_a) <= 2.0)) {
    return Status::Error(
        "z_a: must be a finite height within +-2 m of the wheel centre");
  }
  if (!(e.fmax >= 0) || e.fmax > limits.force_max) {
    std::snprintf(text, sizeof(text),
                  "fmax: must be >= 0 N and <= safety.force_max = %.0f N "
                  "(rig.yaml)",
                  limits.force_max);
    return Status::Error(text);
  }
  if (!(e.duration > 0) || e.duration > 3600) {
    return Status::Error("ramp time: must be within (0, 3600] s");
  }
  if (!(e.hold >= 0) || e.hold > 3600) {
    return Status::Error("hold: must be within [0, 3600] s");
  }
  if (!(e.return_duration >= 0) || e.return_duration > 3600) {
    return Status::Error("return ramp time: must be within [0, 3600] s");
  }
  // The limiter would lag a faster profile, and a run could then end with
  // a force still applied.
  const double fastest =
      std::max({e.fmax / p.lead_in, 2 * e.fmax / e.duration,
                e.return_duration > 0 ? 2 * e.fmax / e.return_duration : 0.0,
                e.fmax / p.ramp_down});
  if (fastest > limits.force_rate_max) {
    std::snprintf(text, sizeof(text),
                  "the run would change the force at %.0f N/s, beyond "
                  "safety.force_rate_max = %.0f N/s (rig.yaml: lengthen the "
                  "ramp, run_profile.lead_in or run_profile.ramp_down)",
                  fastest, limits.force_rate_max);
    return Status::Error(text);
  }
  return Status::Ok();
}

namespace {

Status RunAndRecord(const KcrigConfig& config, const RigConfig& rig_config,
                    RigInterface* rig, const RigSessionOptions& options,
                    RigSessionResult* result) {
  KCRIG_RETURN_IF_ERROR(ValidateRunRequest(rig_config, options));
  KCRIG_RETURN_IF_ERROR(CreateLogDir(options.log_dir));
  const RunProfile profile(rig_config.profile, options.excitation);
  SpscRing<CycleRecord> ring(kRingCapacity);
  RunLogger logger(LoggerOptionsFor(rig_config, options, profile));
  ControlLoop loop(config.model, LoopOptionsFor(rig_config, options), rig,
                   &ring, options.stop_signal);
  loop.add_log_failure(&logger.write_failed());
  if (rig != nullptr) loop.add_log_failure(rig->record_write_failed());
  KCRIG_RETURN_IF_ERROR(logger.Open());
  logger.Start(&ring);
  const Status activated = RunOnRig(
      rig_config.realtime, IsRealTime(options.clock), rig, &loop, result);
  logger.Stop();
  if (!activated.ok()) {
    logger.Discard();
    return activated;
  }

  const LoopResult& lr = result->loop;
  const double period = rig_config.period;
  const nlohmann::ordered_json transport = TransportCounters(rig);
  result->completed = lr.cause == TripCause::kNone;
  result->trip_message = TripMessage(
      lr, period,
      lr.cause == TripCause::kLogWrite
          ? (logger.write_failed() ? logger.WriteFailure()
                                   : rig->RecordWriteFailure())
      : transport.contains("fault") && transport["fault"].is_string()
          ? transport["fault"].get<std::string>()
          : "the transport failed");
  RunLog& log = logger.log();
  result->filled_rows = logger.filled_rows();
  result->logged_rows = logger.rows();
  result->timing = MakeTimingFile(loop.timing(), lr, result->realtime, period,
                                  rig_config.budget, rig != nullptr);
  result->timing.trip = result->trip_message;
  result->timing.release_error = result->release_error;
  // Figures of a loop a fault ended early are not a pass; the trip says why.
  if (!result->completed) result->timing.within_budget = false;
  if (options.log_dir.empty()) return Status::Ok();

  RunMetadata& m = log.metadata;
  m.rate = 1.0 / period;
  m.excitation = options.excitation;
  m.geometry = GeometryFingerprint(config.model);
  m.sigma_position = config.experiment.sigma_position;
  m.sigma_angle = config.experiment.sigma_angle;
  m.transport = rig != nullptr ? rig->Describe() : "none";
  if (options.truth != nullptr) {
    m.synthetic = options.truth->synthetic;
    m.noise_added = options.truth->noise_added;
    m.seed = options.truth->seed;
    m.truth_parameters = options.truth->truth_parameters;
    m.truth_effects = options.truth->truth_effects;
  }
  m.hil_json = HilJson(rig_config, options, profile, *result,
                       logger.rows_without_fresh_sample(), transport);
  KCRIG_RETURN_IF_ERROR(logger.Finish(options.log_dir));
  const std::string timing_path =
      (std::filesystem::path(options.log_dir) / "timing.json").string();
  // A virtual clock's run has no timing: its phases took CPU, not time (an
  // earlier run's file would tell of another run).
  if (!IsRealTime(options.clock)) {
    std::error_code ignored;
    std::filesystem::remove(timing_path, ignored);
    return Status::Ok();
  }
  return WriteFilesAtomically(
      {{timing_path, TimingFileToJson(result->timing)}});
}

RunMonitor::Run MonitoredRun(const RigConfig& rig_config,
                             const RigSessionOptions& options,
                             const RigInterface* rig) {
  RunMonitor::Run run;
  run.rig = rig != nullptr ? rig->Describe() : "none";
  run.excitation = options.excitation;
  run.limits = rig_config.safety;
  run.period = rig_config.period;
  run.duration = RunProfile(rig_config.profile, options.excitation).duration();
  run.real_time = IsRealTime(options.clock);
  run.log_dir = options.log_dir;
  return run;
}

}  // namespace

Status RunRigSession(const KcrigConfig& config, const RigConfig& rig_config,
                     RigInterface* rig, const RigSessionOptions& options,
                     RigSessionResult* result) {
  *result = RigSessionResult();
  RunMonitor* monitor = options.monitor;
  if (monitor != nullptr) {
    monitor->RunStarted(MonitoredRun(rig_config, options, rig));
  }
  const Status status = RunAndRecord(config, rig_config, rig, options, result);
  if (monitor != nullptr) {
    const bool completed = status.ok() && result->completed;
    monitor->RunEnded(completed,
                      !status.ok() ? status.message()
                      : completed  ? std::string("completed")
                                   : result->trip_message,
                      result->loop);
  }
  return status;
}

std::string LiveTripCause(const CycleRecord& record, double period) {
  LoopResult loop;
  loop.cause = record.cause;
  loop.trip_cycle = record.cycle;
  loop.trip_channel = record.trip_channel;
  loop.rig_fault_code = record.rig_fault;
  loop.signal = record.stop_signal;
  return TripCauseText(loop, period, "the run's end says what failed");
}

}  // namespace kcrig
