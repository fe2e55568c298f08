#include "apps/timing_check_command.h"

#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "apps/cli_util.h"
#include "apps/progress.h"
#include "base/atomic_files.h"
#include "hil/rig_config.h"
#include "hil/rig_factory.h"
#include "hil/rig_session.h"
#include "records/run_log.h"
#include "rt_core/model/model_config.h"
#include "rt_core/runtime/cycle_timer.h"
#include "rt_core/runtime/realtime.h"

namespace kcrig {
namespace {

// Exit status when the timing is outside the budget.
constexpr int kOverBudget = 4;
constexpr int kTripped = 3;  // as kcrig run after a safety trip

struct TimingCheckArgs {
  std::string config_dir;
  std::string rig;
  double duration = 10;
  std::optional<double> rate;
  double baseline = 5;
  std::string out;
  bool quiet = false;
};

void PrintRow(const char* name, const TimingStatistics& s) {
  std::printf("  %-22s %8.1f %8.1f %8.1f %8.1f %8.1f %9.1f\n", name,
              s.min() * 1e-3, s.mean() * 1e-3, s.Percentile(0.5) * 1e-3,
              s.Percentile(0.99) * 1e-3, s.Percentile(0.999) * 1e-3,
              s.max() * 1e-3);
}

// The config and rig.yaml with --rate applied, the options checked, and the
// rig (none for the model alone) configured.
Status PrepareTimingCheck(const TimingCheckArgs& args, KcrigConfig* config,
                          RigConfig* rig_config,
                          std::unique_ptr<RigInterface>* rig) {
  KCRIG_RETURN_IF_ERROR(LoadConfig(args.config_dir, config));
  KCRIG_RETURN_IF_ERROR(CheckOutput("--out", args.out, {}));
  KCRIG_RETURN_IF_ERROR(LoadRigConfig(config->directory, rig_config));
  if (args.rate) {
    if (!(*args.rate >= 10 && *args.rate <= 10000)) {
      return Status::Error("--rate: must be within [10, 10000] Hz");
    }
    rig_config->period = 1.0 / *args.rate;
    const Status status = CheckLimitsAtPeriod(*rig_config);
    if (!status.ok()) return Status::Error("--rate: " + status.message());
    if (rig_config->modbus.response_timeout > 0.5 * rig_config->period) {
      return Status::Error(
          "--rate: the period is shorter than twice modbus.response_timeout "
          "(rig.yaml)");
    }
  }
  if (!(args.duration > 0 && args.duration <= 3600) ||
      !(args.baseline >= 0 && args.baseline <= 3600)) {
    return Status::Error(
        "--duration and --baseline: must be within (0, 3600] s");
  }
  if (args.rig.empty()) return Status::Ok();
  KCRIG_RETURN_IF_ERROR(MakeRig(args.rig, *rig_config, "", rig));
  return (*rig)->Configure();
}

// The loop with zero force (a timing check never loads the rig) for
// --duration, through the rig if any.
Status RunZeroForceLoop(const TimingCheckArgs& args, const KcrigConfig& config,
                        const RigConfig& rig_config, RigInterface* rig,
                        ProgressLine* progress, RigSessionResult* result) {
  RigSessionOptions options;
  options.excitation = {config.experiment.phi, config.experiment.z_a, 0.0,
                        std::max(args.duration, 1.0)};
  options.max_duration = args.duration;
  options.stop_signal = &InstallStopSignalHandlers();
  options.on_progress = [&](double t, RunPhase) {
    char text[96];
    std::snprintf(text, sizeof(text),
                  "kcrig timing-check: loop t = %.1f / %.1f s", t,
                  args.duration);
    progress->Show(text, t / args.duration);
  };
  const Status status = RunRigSession(config, rig_config, rig, options, result);
  progress->Clear();
  if (!status.ok()) return status;
  for (const std::string& warning : result->realtime.warnings) {
    std::fprintf(stderr, "kcrig timing-check: warning: %s\n", warning.c_str());
  }
  return Status::Ok();
}

void PrintPhases(const TimingFile& timing) {
  std::printf("  %-22s %8s %8s %8s %8s %8s %9s  [us]\n", "phase", "min", "mean",
              "p50", "p99", "p99.9", "max");
  for (const char* name : {"wakeup", "read", "compute", "write", "cycle"}) {
    const TimingPhase& p = timing.phases.at(name);
    std::printf("  %-22s %8.1f %8.1f %8.1f %8.1f %8.1f %9.1f\n", name, p.min_us,
                p.mean_us, p.p50_us, p.p99_us, p.p999_us, p.max_us);
  }
}

// The machine's wake-up latency beside the loop's, printed and recorded.
void AddBaseline(const TimingStatistics& baseline,
                 const RealtimeReport& realtime, double duration,
                 TimingFile* timing) {
  PrintRow("baseline wake-up", baseline);
  const double kcrig_p99 = timing->phases["wakeup"].p99_us;
  const double ratio = baseline.Percentile(0.99) > 0
                           ? kcrig_p99 * 1e3 / baseline.Percentile(0.99)
                           : 0.0;
  std::printf(
      "  wake-up p99: kcrig %.1f us vs the machine's baseline %.1f us "
      "(ratio %.2f; cyclictest-like, same priority and period)\n",
      kcrig_p99, baseline.Percentile(0.99) * 1e-3, ratio);
  timing->has_baseline = true;
  TimingBaseline& b = timing->baseline;
  b.duration_s = duration;
  b.sched_fifo = realtime.fifo;
  b.wakeup.count = baseline.count();
  b.wakeup.min_us = baseline.min() * 1e-3;
  b.wakeup.mean_us = baseline.mean() * 1e-3;
  b.wakeup.p50_us = baseline.Percentile(0.5) * 1e-3;
  b.wakeup.p99_us = baseline.Percentile(0.99) * 1e-3;
  b.wakeup.p999_us = baseline.Percentile(0.999) * 1e-3;
  b.wakeup.max_us = baseline.max() * 1e-3;
  b.kcrig_to_baseline_p99 = ratio;
}

// The link over the whole run, its end included: a rig that dies in the
// last cycles (before the watchdog's count) is no pass either. Lost rig
// samples are reported but pass: another client reading the rig (an HMI)
// takes samples this loop never sees.
void JudgeLink(TimingFile* timing) {
  std::printf(
      "  link: %lld read errors, %lld write errors, %lld stale samples, "
      "%lld rig samples lost; release %s\n",
      static_cast<long long>(timing->read_errors),
      static_cast<long long>(timing->write_errors),
      static_cast<long long>(timing->stale_samples),
      static_cast<long long>(timing->lost_rig_samples),
      timing->release_error.empty()
          ? "ok"
          : ("failed (" + timing->release_error + ")").c_str());
  if (timing->read_errors + timing->write_errors + timing->stale_samples > 0 ||
      !timing->release_error.empty()) {
    timing->violations.push_back("the link failed (see link)");
    timing->within_budget = false;
  }
}

// The budget's verdict. A loop that a fault or a signal ended early measured
// only part of the run: never a pass, whatever its figures.
void PrintVerdict(const TimingFile& timing, const RigSessionResult& result) {
  for (const std::string& violation : timing.violations) {
    std::printf("  over budget: %s\n", violation.c_str());
  }
  if (!result.completed) {
    std::printf("  %s: the loop did not run to its end\n",
                result.trip_message.c_str());
  }
  std::printf("  budget (rig.yaml timing_budget): %s\n",
              !result.completed      ? "NOT CHECKED (the loop stopped early)"
              : timing.within_budget ? "within"
                                     : "EXCEEDED");
}

int RunTimingCheck(const TimingCheckArgs& args) {
  const CommandError fail("timing-check");
  KcrigConfig config;
  RigConfig rig_config;
  std::unique_ptr<RigInterface> rig;
  Status status = PrepareTimingCheck(args, &config, &rig_config, &rig);
  if (!status.ok()) return fail(status);
  ProgressLine progress(args.quiet);

  // The machine's baseline first, with the loop's scheduling.
  TimingStatistics baseline;
  RealtimeReport baseline_realtime;
  if (args.baseline > 0) {
    progress.Show("kcrig timing-check: baseline wake-up latency (" +
                  std::to_string(static_cast<int>(args.baseline)) + " s)");
    baseline_realtime = SetUpRealtime(rig_config.realtime);
    baseline = MeasureWakeupLatency(std::llround(rig_config.period * 1e9),
                                    args.baseline);
    LeaveRealtime();
  }
  RigSessionResult result;
  status =
      RunZeroForceLoop(args, config, rig_config, rig.get(), &progress, &result);
  if (!status.ok()) return fail(status);

  // The statistics printed are timing.json's: one source.
  TimingFile timing = result.timing;
  std::printf("kcrig timing-check: %.0f Hz for %.1f s, transport %s\n",
              1.0 / rig_config.period, args.duration,
              rig ? rig->Describe().c_str() : "none (model only)");
  PrintPhases(timing);
  if (args.baseline > 0) {
    AddBaseline(baseline, baseline_realtime, args.baseline, &timing);
  }
  std::printf(
      "  overruns %lld (cycles skipped %lld, of them %lld by late wake-ups)\n",
      static_cast<long long>(result.loop.overruns),
      static_cast<long long>(result.loop.skipped_cycles),
      static_cast<long long>(result.loop.skipped_by_late_wakeup));
  JudgeLink(&timing);
  PrintVerdict(timing, result);
  if (!args.out.empty()) {
    status = WriteFilesAtomically({{args.out, TimingFileToJson(timing)}});
    if (!status.ok()) return fail(status);
    std::printf("  wrote %s\n", args.out.c_str());
  }
  if (result.loop.cause == TripCause::kSignal) {
    return 128 + result.loop.signal;
  }
  if (!result.completed) return kTripped;
  return timing.within_budget ? 0 : kOverBudget;
}

}  // namespace

void AddTimingCheckCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<TimingCheckArgs>();
  CLI::App* cmd = app->add_subcommand(
      "timing-check",
      "Run the step loop (zero force) and check its per-phase timing against "
      "the budget of rig.yaml; exit 0 only within budget (4 otherwise; 3 when "
      "a fault ended the loop, 130/143 when a signal did)");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--rig", args->rig,
                  "Transport to include, modbus-tcp://HOST:PORT (default: "
                  "none, the model alone)");
  cmd->add_option("--duration", args->duration, "Loop run time [s]");
  cmd->add_option_function<double>(
      "--rate", [args](const double& rate) { args->rate = rate; },
      "Loop rate [Hz] (default: rig.yaml loop.period)");
  cmd->add_option("--baseline", args->baseline,
                  "Time for the machine's baseline wake-up latency [s] (0: "
                  "skip)");
  cmd->add_option("--out", args->out, "timing.json to write");
  cmd->add_flag("--quiet", args->quiet, "No progress line");
  cmd->callback(
      [args, run] { *run = [args] { return RunTimingCheck(*args); }; });
}

}  // namespace kcrig
