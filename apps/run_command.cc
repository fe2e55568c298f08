#include "apps/run_command.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "apps/cli_util.h"
#include "apps/console_options.h"
#include "apps/progress.h"
#include "apps/sil_rig_options.h"
#include "emulator/sil_rig.h"
#include "hil/rig_config.h"
#include "hil/rig_factory.h"
#include "hil/rig_session.h"
#include "rt_core/model/channels.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

// Exit status of a run that tripped (0: completed, 1: bad input or I/O).
constexpr int kTripped = 3;

struct RunArgs {
  std::string config_dir;
  std::string rig;
  SilRigArgs sil;
  ConsoleArgs console;
  ExcitationArgs excitation;
  std::string log_dir;
  bool quiet = false;
};

// The embedded SIL rig at rest, and its link with the faults to inject.
Status ConnectSilRig(const SilRigArgs& args, const KcrigConfig& config,
                     std::unique_ptr<SilRig>* sil,
                     std::unique_ptr<RigInterface>* link, RunMetadata* truth,
                     std::string* described) {
  PlantConfig plant;
  std::vector<InjectedFault> faults;
  KCRIG_RETURN_IF_ERROR(LoadSilPlant(args, config, &plant, &faults));
  *sil = std::make_unique<SilRig>(config, plant);
  KCRIG_RETURN_IF_ERROR((*sil)->Start());
  *link = (*sil)->Connect(std::move(faults));
  *truth = (*sil)->Truth();
  *described = DescribeSilRig(args, plant);
  return Status::Ok();
}

void PrintOutcome(const char* who, const RigSessionResult& r,
                  const std::string& log_dir) {
  const LoopResult& l = r.loop;
  std::printf("%s: %s\n", who,
              r.completed ? "completed" : r.trip_message.c_str());
  std::printf(
      "  cycles %lld, fresh samples %lld, rows without a fresh sample %lld "
      "(read errors %lld, stale %lld, cycles skipped by overruns %lld, of "
      "them %lld by late wake-ups), lost rig samples %lld, overruns %lld\n",
      static_cast<long long>(l.cycles), static_cast<long long>(l.fresh),
      static_cast<long long>(r.logged_rows - l.fresh),
      static_cast<long long>(l.read_errors), static_cast<long long>(l.stale),
      static_cast<long long>(r.filled_rows),
      static_cast<long long>(l.skipped_by_late_wakeup),
      static_cast<long long>(l.lost_rig_samples),
      static_cast<long long>(l.overruns));
  if (!log_dir.empty()) {
    const std::filesystem::path dir(log_dir);
    const bool timing = std::filesystem::exists(dir / "timing.json");
    const bool can = std::filesystem::exists(dir / "can.log");
    std::printf("  wrote %s/%s, run.json%s%s\n", log_dir.c_str(),
                std::filesystem::exists(dir / "run.csv")
                    ? "run.csv"
                    : "run.csv.partial (incomplete)",
                timing ? ", timing.json" : "", can ? ", can.log" : "");
  }
}

int RunRun(const RunArgs& args) {
  const CommandError fail("run");
  KcrigConfig config;
  Status status = LoadConfig(args.config_dir, &config);
  if (!status.ok()) return fail(status);
  RigConfig rig_config;
  status = LoadRigConfig(config.directory, &rig_config);
  if (!status.ok()) return fail(status);
  RigSessionOptions options;
  options.excitation = ResolveRamp(args.excitation, config.experiment);
  options.log_dir = args.log_dir;
  status = ValidateRunRequest(rig_config, options);
  if (!status.ok()) return fail(status);
  if (args.log_dir.empty()) return fail(Status::Error("give --log-dir DIR"));

  status = CheckSilRigOptions(args.sil, args.rig);
  if (!status.ok()) return fail(status);
  std::unique_ptr<SilRig> sil;  // outlives its link, `rig`
  RunMetadata truth;
  std::string described;
  std::unique_ptr<RigInterface> rig;
  status = args.rig == "sim"
               ? ConnectSilRig(args.sil, config, &sil, &rig, &truth, &described)
               : MakeRig(args.rig, rig_config, args.log_dir, &rig);
  if (!status.ok()) return fail(status);
  if (described.empty()) described = rig->Describe();
  std::unique_ptr<LiveConsole> console;
  // The embedded rig's virtual clock pins nothing.
  status =
      StartConsole(args.console, "kcrig run",
                   args.rig == "sim" ? -1 : rig_config.realtime.cpu, &console);
  if (!status.ok()) return fail(status);
  if (console != nullptr) options.monitor = &console->feed();
  if (sil != nullptr) {
    sil->clock()->set_pace(SilRigPace(args.sil, console != nullptr));
    described += DescribePace(sil->clock()->pace());
    options.clock = sil->clock();
    options.truth = &truth;
  }
  if (console != nullptr) console->feed().Title("kcrig run");
  status = rig->Configure();
  if (!status.ok()) {
    if (console != nullptr) console->Shutdown(status.message());
    return fail(status);
  }
  options.stop_signal = &InstallStopSignalHandlers();
  ProgressLine progress(args.quiet);
  const RunProfile profile(rig_config.profile, options.excitation);
  options.on_progress = [&](double t, RunPhase phase) {
    char text[128];
    std::snprintf(text, sizeof(text), "kcrig run: %-9s t = %5.2f / %.2f s",
                  RunPhaseName(phase), t, profile.duration());
    progress.Show(text);
  };
  options.on_warning = [&](const std::string& warning) {
    progress.Clear();
    std::fprintf(stderr, "kcrig run: warning: %s\n", warning.c_str());
  };
  std::printf(
      "kcrig run: %s, phi %.2f deg, z_a %.3f m, Fmax %.2f kN, ramp %.2f s "
      "(whole run %.2f s at %.0f Hz)\n",
      described.c_str(), options.excitation.phi / kDegree,
      options.excitation.z_a, options.excitation.fmax * 1e-3,
      options.excitation.duration, profile.duration(), 1.0 / rig_config.period);
  std::fflush(stdout);
  RigSessionResult result;
  status = RunRigSession(config, rig_config, rig.get(), options, &result);
  progress.Clear();
  for (const std::string& warning : result.realtime.warnings) {
    std::fprintf(stderr, "kcrig run: warning: %s\n", warning.c_str());
  }
  if (!status.ok()) {
    if (console != nullptr) console->Shutdown(status.message());
    return fail(status);
  }
  PrintOutcome("kcrig run", result, args.log_dir);
  std::fflush(stdout);
  if (console != nullptr) {
    console->Shutdown(result.completed ? std::string("the run completed")
                                       : result.trip_message);
  }
  return result.completed ? 0 : kTripped;
}

}  // namespace

void AddRunCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* cmd = app->add_subcommand(
      "run",
      "One HIL experiment on a rig (a transport, or the embedded SIL rig): "
      "tare, lead-in, the ramp, "
      "ramp-down; safety trips ramp the force to zero (exit 3)");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--rig", args->rig,
                  "sim (the embedded SIL rig, on a virtual clock), "
                  "modbus-tcp://HOST:PORT, modbus-rtu://DEVICE or can:IFACE")
      ->required();
  AddSilRigOptions(cmd, &args->sil, /*with_faults=*/true);
  AddExcitationOptions(cmd, &args->excitation);
  cmd->add_option("--log-dir", args->log_dir,
                  "Directory for run.csv, run.json, timing.json (not on the "
                  "virtual clock of --rig sim) (and the "
                  "CAN bus log can.log)")
      ->required();
  AddConsoleOptions(cmd, &args->console);
  cmd->add_flag("--quiet", args->quiet, "No progress line");
  cmd->callback([args, run] { *run = [args] { return RunRun(*args); }; });
}

}  // namespace kcrig
