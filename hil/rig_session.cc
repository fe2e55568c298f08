#include "hil/rig_session.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <thread>

#include "nlohmann/json.hpp"
#include "records/run_log.h"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

constexpr std::size_t kRingCapacity = 1 << 16;  // 65 s at 1 kHz

LogSample ToSample(const CycleRecord& r, double period) {
  LogSample s;
  s.t = static_cast<double>(r.cycle) * period;
  s.force << r.force[0], r.force[1], r.force[2];
  s.y << r.y[0], r.y[1], r.y[2], r.y[3], r.y[4], r.y[5];
  s.commanded << r.commanded[0], r.commanded[1], r.commanded[2];
  s.fresh = r.fresh;
  s.phase = RunPhaseName(r.phase);
  s.safety = static_cast<int>(r.safety);
  s.rig_sample = r.rig_sample;
  s.rig_status = r.rig_status;
  s.predicted << r.predicted[0], r.predicted[1], r.predicted[2], r.predicted[3],
      r.predicted[4], r.predicted[5];
  return s;
}

nlohmann::ordered_json PhaseJson(const TimingStatistics& s) {
  nlohmann::ordered_json histogram = nlohmann::ordered_json::array();
  for (const auto& [lower, count] : s.Histogram()) {
    histogram.push_back({lower * 1e-3, count});
  }
  return {{"count", s.count()},
          {"min_us", s.min() * 1e-3},
          {"mean_us", s.mean() * 1e-3},
          {"p50_us", s.Percentile(0.5) * 1e-3},
          {"p99_us", s.Percentile(0.99) * 1e-3},
          {"p999_us", s.Percentile(0.999) * 1e-3},
          {"max_us", s.max() * 1e-3},
          {"histogram_us", histogram}};
}

std::string Channel(int k) {
  return k >= 0 && k < kNumChannels ? kChannelNames[k] : "?";
}

// `transport_fault`: what the transport reported, for kTransportFault.
std::string TripMessage(const LoopResult& loop, double period,
                        const std::string& transport_fault) {
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
      what += " (the rig reported a fault or stopped being enabled)";
      break;
    case TripCause::kInvalidMeasurement:
      what += " (the rig sent a non-finite value)";
      break;
    case TripCause::kTransportFault:
      what += " (" + transport_fault + ")";
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
  return "tripped: " + what + at + "; force ramped to zero and disabled";
}

}  // namespace

std::string TimingJson(const LoopTiming& timing, const LoopResult& loop,
                       const RealtimeReport& realtime, double period,
                       const TimingBudget& budget, bool with_transport) {
  std::vector<std::string> violations;
  const bool within =
      WithinBudget(timing, period, budget, with_transport, &violations);
  nlohmann::ordered_json doc;
  doc["format"] = "kcrig timing 1";
  doc["period_us"] = period * 1e6;
  doc["cycles"] = loop.cycles;
  doc["overruns"] = loop.overruns;
  doc["skipped_cycles"] = loop.skipped_cycles;
  doc["dropped_log_records"] = loop.dropped_records;
  doc["realtime"] = {{"sched_fifo", realtime.fifo},
                     {"cpu_affinity", realtime.affinity},
                     {"memory_locked", realtime.locked},
                     {"no_cpu_idle", realtime.no_cpu_idle},
                     {"warnings", realtime.warnings}};
  doc["phases"] = {{"wakeup", PhaseJson(timing.wakeup)},
                   {"read", PhaseJson(timing.read)},
                   {"compute", PhaseJson(timing.compute)},
                   {"write", PhaseJson(timing.write)},
                   {"cycle", PhaseJson(timing.cycle)}};
  doc["budget"] = {{"compute_p999_fraction", budget.compute_p999_fraction},
                   {"wakeup_p99_us", budget.wakeup_p99 * 1e6},
                   {"cycle_p999_fraction", budget.cycle_p999_fraction},
                   {"within", within},
                   {"violations", violations}};
  return doc.dump(2) + "\n";
}

bool WithinBudget(const LoopTiming& timing, double period,
                  const TimingBudget& budget, bool with_transport,
                  std::vector<std::string>* violations) {
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
  return violations->empty();
}

Status ValidateRunRequest(const RigConfig& rig_config,
                          const RigSessionOptions& options) {
  const SafetyLimits& limits = rig_config.safety;
  const RunProfileTimes& p = rig_config.profile;
  char text[200];
  if (!std::isfinite(options.phi)) return Status::Error("phi: must be finite");
  if (!(std::abs(options.z_a) <= 2.0)) {
    return Status::Error(
        "z_a: must be a finite height within +-2 m of the wheel centre");
  }
  if (!(options.fmax >= 0) || options.fmax > limits.force_max) {
    std::snprintf(text, sizeof(text),
                  "fmax: must be >= 0 N and <= safety.force_max = %.0f N "
                  "(rig.yaml)",
                  limits.force_max);
    return Status::Error(text);
  }
  if (!(options.tf > 0) || options.tf > 3600) {
    return Status::Error("ramp time: must be within (0, 3600] s");
  }
  if (!(options.hold >= 0) || options.hold > 3600) {
    return Status::Error("hold: must be within [0, 3600] s");
  }
  if (!(options.return_duration >= 0) || options.return_duration > 3600) {
    return Status::Error("return ramp time: must be within [0, 3600] s");
  }
  // The limiter would lag a faster profile, and a run could then end with
  // a force still applied.
  const double fastest = std::max(
      {options.fmax / p.lead_in, 2 * options.fmax / options.tf,
       options.return_duration > 0 ? 2 * options.fmax / options.return_duration
                                   : 0.0,
       options.fmax / p.ramp_down});
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

Status RunRigSession(const KcrigConfig& config, const RigConfig& rig_config,
                     RigInterface* rig, const RigSessionOptions& options,
                     RigSessionResult* result) {
  namespace fs = std::filesystem;
  *result = RigSessionResult();
  const double period = rig_config.period;
  const Status valid = ValidateRunRequest(rig_config, options);
  if (!valid.ok()) return valid;
  if (!options.log_dir.empty()) {
    std::error_code error;
    fs::create_directories(options.log_dir, error);
    if (error || !fs::is_directory(options.log_dir)) {
      return Status::Error("--log-dir " + options.log_dir +
                           ": cannot create the directory");
    }
  }
  LoopOptions loop_options;
  loop_options.period = period;
  loop_options.phi = options.phi;
  loop_options.z_a = options.z_a;
  loop_options.fmax = options.fmax;
  loop_options.tf = options.tf;
  loop_options.hold = options.hold;
  loop_options.return_duration = options.return_duration;
  loop_options.profile = rig_config.profile;
  loop_options.safety = rig_config.safety;
  loop_options.max_duration = options.max_duration;

  SpscRing<CycleRecord> ring(kRingCapacity);
  ControlLoop loop(config.model, loop_options, rig, &ring, options.stop_signal);
  const RunProfile profile(rig_config.profile, options.tf, options.hold,
                           options.return_duration);

  RunLog log;
  log.has_measured_force = true;
  log.has_commanded_force = true;
  log.has_loop_columns = true;
  const bool keep_log = !options.log_dir.empty();
  // The logger streams rows to run.csv.partial as they come (a crash of
  // this process keeps every row up to it); the end renames it to run.csv
  // beside its sidecar.
  const std::string csv_path =
      keep_log ? (fs::path(options.log_dir) / "run.csv").string() : "";
  const std::string partial_path = csv_path + ".partial";
  std::FILE* partial = nullptr;
  if (keep_log) {
    // Up to 10 minutes up front; a longer run grows the log in the logger
    // thread.
    log.samples.reserve(
        static_cast<size_t>(std::min(profile.duration(), 600.0) / period) + 16);
    partial = std::fopen(partial_path.c_str(), "wb");
    if (partial == nullptr) {
      return Status::Error(partial_path + ": cannot write (" +
                           std::strerror(errno) + ")");
    }
    const std::string header = RunLogCsvHeader(log);
    std::fwrite(header.data(), 1, header.size(), partial);
  }
  bool stream_failed = false;

  std::atomic<bool> loop_done{false};
  std::thread logger([&] {
    CycleRecord record;
    std::int64_t next_cycle = 0;
    auto last_progress = std::chrono::steady_clock::now();
    auto last_warning = last_progress;
    std::int64_t skipped_since_warning = 0;
    std::string rows;
    size_t streamed = 0;  // samples already in `rows` or on disk
    for (;;) {
      const bool done = loop_done.load(std::memory_order_acquire);
      while (ring.Pop(&record)) {
        if (!keep_log) {
          next_cycle = record.cycle + 1;
          continue;
        }
        // Cycles skipped by an overrun get a row without a fresh sample, so
        // that the log's time column stays uniform.
        while (next_cycle < record.cycle && !log.samples.empty()) {
          LogSample filler = log.samples.back();
          filler.t = static_cast<double>(next_cycle++) * period;
          filler.fresh = false;
          log.samples.push_back(filler);
          ++result->filled_rows;
          ++skipped_since_warning;
        }
        log.samples.push_back(ToSample(record, period));
        next_cycle = record.cycle + 1;
      }
      if (keep_log && streamed < log.samples.size()) {
        for (; streamed < log.samples.size(); ++streamed) {
          AppendRunLogCsvRow(log, log.samples[streamed], &rows);
        }
        stream_failed |=
            std::fwrite(rows.data(), 1, rows.size(), partial) != rows.size() ||
            std::fflush(partial) != 0;
        rows.clear();
      }
      if (done) break;
      const auto now = std::chrono::steady_clock::now();
      if (options.on_warning && skipped_since_warning > 0 &&
          now - last_warning >= std::chrono::seconds(1)) {
        options.on_warning(
            "overrun: " + std::to_string(skipped_since_warning) +
            " cycle(s) skipped since the last warning (see timing.json)");
        skipped_since_warning = 0;
        last_warning = now;
      }
      if (options.on_progress &&
          now - last_progress > std::chrono::milliseconds(250)) {
        last_progress = now;
        const double t = static_cast<double>(next_cycle) * period;
        options.on_progress(t, profile.Phase(t));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });

  // Real-time set-up first (mlockall faults every page in, which takes
  // time), then enable the rig, whose command watchdog is running from then.
  result->realtime = SetUpRealtime(rig_config.realtime);
  Status activated = Status::Ok();
  if (rig != nullptr) activated = rig->Activate();
  if (activated.ok()) result->loop = loop.Run();
  LeaveRealtime();
  loop_done.store(true, std::memory_order_release);
  logger.join();
  if (rig != nullptr) {
    // Zero force and disabled, whatever ended the loop (best effort when
    // the link is gone: the rig's own watchdog then does it).
    if (!rig->Deactivate().ok()) rig->OnError();
  }
  if (!activated.ok()) {
    if (partial != nullptr) {
      std::fclose(partial);
      std::remove(partial_path.c_str());
    }
    return activated;
  }

  const LoopResult& lr = result->loop;
  result->completed = lr.cause == TripCause::kNone;
  nlohmann::ordered_json transport = nlohmann::ordered_json::object();
  if (rig != nullptr) {
    transport = nlohmann::ordered_json::parse(rig->CountersJson(), nullptr,
                                              /*allow_exceptions=*/false);
    if (transport.is_discarded()) transport = nlohmann::ordered_json::object();
  }
  result->trip_message =
      TripMessage(lr, period,
                  transport.contains("fault") && transport["fault"].is_string()
                      ? transport["fault"].get<std::string>()
                      : "the transport failed");
  result->logged_rows = static_cast<std::int64_t>(log.samples.size());
  result->timing_json = TimingJson(loop.timing(), lr, result->realtime, period,
                                   rig_config.budget, rig != nullptr);
  if (options.log_dir.empty()) return Status::Ok();

  RunMetadata& m = log.metadata;
  m.rate = 1.0 / period;
  m.phi = options.phi;
  m.z_a = options.z_a;
  m.fmax = options.fmax;
  m.duration = options.tf;
  m.hold = options.hold;
  m.geometry = GeometryFingerprint(config.model);
  m.return_duration = options.return_duration;
  m.sigma_position = config.experiment.sigma_position;
  m.sigma_angle = config.experiment.sigma_angle;
  m.transport = rig != nullptr ? rig->Describe() : "none";
  const RunProfileTimes& p = rig_config.profile;
  nlohmann::ordered_json hil;
  hil["profile_s"] = {
      {"tare", p.tare},           {"lead_in", p.lead_in},
      {"settle", p.settle},       {"ramp", options.tf},
      {"hold", options.hold},     {"return", options.return_duration},
      {"ramp_down", p.ramp_down}, {"ramp_start", profile.ramp_start()}};
  hil["completed"] = result->completed;
  hil["safety"] = {
      {"tripped", !result->completed},
      {"cause", TripCauseName(lr.cause)},
      {"message", result->trip_message},
      {"trip_time_s",
       lr.trip_cycle >= 0 ? static_cast<double>(lr.trip_cycle) * period : -1.0},
      {"limited_commands", lr.limited_commands}};
  hil["cycles"] = lr.cycles;
  hil["fresh_samples"] = lr.fresh;
  hil["stale_samples"] = lr.stale;
  hil["read_errors"] = lr.read_errors;
  hil["write_errors"] = lr.write_errors;
  hil["lost_rig_samples"] = lr.lost_rig_samples;
  hil["overruns"] = lr.overruns;
  hil["skipped_cycles"] = lr.skipped_cycles;
  hil["rows_without_fresh_sample"] = static_cast<std::int64_t>(
      std::count_if(log.samples.begin(), log.samples.end(),
                    [](const LogSample& s) { return !s.fresh; }));
  hil["dropped_log_records"] = lr.dropped_records;
  hil["rest_pose"] =
      std::vector<double>(lr.rest_pose.data(), lr.rest_pose.data() + 6);
  hil["realtime_warnings"] = result->realtime.warnings;
  hil["transport"] = transport;
  m.hil_json = hil.dump();
  if (log.samples.size() < 2) {
    std::fclose(partial);
    std::remove(partial_path.c_str());
    return Status::Error(options.log_dir +
                         ": the run ended before two cycles were logged");
  }
  if (std::fclose(partial) != 0 || stream_failed) {
    return Status::Error(partial_path +
                         ": writing the log failed (disk "
                         "full?); the rows written so far are "
                         "in this file");
  }
  Status status = FinishStreamedRunLog(partial_path, csv_path, log);
  if (!status.ok()) return status;
  return WriteFilesAtomically(
      {{(fs::path(options.log_dir) / "timing.json").string(),
        result->timing_json}});
}

}  // namespace kcrig
