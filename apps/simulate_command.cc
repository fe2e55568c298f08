#include "apps/simulate_command.h"

#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "apps/cli_util.h"
#include "emulator/simulated_run.h"
#include "records/run_log.h"
#include "rt_core/model/channels.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

struct SimulateArgs {
  std::string config_dir;
  // Unset means "the config's default".
  ExcitationArgs excitation;
  std::optional<double> rate;
  std::optional<double> plant_step;  // the model's integrator.step if unset
  std::vector<std::string> sets;
  std::vector<std::string> effects;
  bool noise = false;
  std::uint64_t seed = 1;
  std::string out;
};

// Resolves command-line values over the config defaults and checks them.
Status ResolveExcitation(const SimulateArgs& args,
                         const ExperimentConfig& experiment,
                         RampExcitation<double>* excitation, double* rate) {
  *excitation = ResolveRamp(args.excitation, experiment);
  *rate = args.rate.value_or(experiment.rate);
  if (!std::isfinite(excitation->phi))
    return Status::Error("--phi: must be finite");
  if (!std::isfinite(excitation->z_a) || std::abs(excitation->z_a) > 2.0) {
    return Status::Error(
        "--z: must be a finite height within +-2 m of the wheel centre");
  }
  if (!std::isfinite(excitation->fmax) || excitation->fmax < 0) {
    return Status::Error("--fmax: must be a finite force >= 0 N");
  }
  if (!std::isfinite(excitation->duration) || excitation->duration <= 0) {
    return Status::Error("--duration: must be > 0 s");
  }
  if (!(excitation->hold >= 0) || excitation->hold > 3600) {
    return Status::Error("--hold: must be within [0, 3600] s");
  }
  if (!(excitation->return_duration >= 0) ||
      excitation->return_duration > 3600) {
    return Status::Error("--return: must be within [0, 3600] s");
  }
  if (!std::isfinite(*rate) || *rate <= 0) {
    return Status::Error("--rate: must be > 0 Hz");
  }
  if (excitation->EndTime() * *rate > 1e7) {
    return Status::Error("--duration x --rate: more than 1e7 samples");
  }
  return Status::Ok();
}

void PrintSummary(const SimulateArgs& args, const RunLog& log,
                  const RampExcitation<double>& excitation) {
  const LogSample& first = log.samples.front();
  // The compliance is read over the up-ramp (a return ramp comes back).
  const size_t top = std::min(log.samples.size() - 1,
                              static_cast<size_t>(std::lround(
                                  excitation.duration * log.metadata.rate)));
  const LogSample& last = log.samples[top];
  std::printf(
      "kcrig simulate: phi %.2f deg, z_a %.3f m, Fmax %.3f kN, tf %.2f s, "
      "%zu samples at %.0f Hz%s\n",
      excitation.phi / kDegree, excitation.z_a, excitation.fmax / 1e3,
      excitation.duration, log.samples.size(), log.metadata.rate,
      args.noise ? ", with sensor noise" : "");
  const double magnitude_span =
      excitation.fmax * (excitation.Profile(last.t) - excitation.Profile(0.0));
  std::printf("  %-8s %12s %12s %14s\n", "channel", "at start", "at +Fmax",
              "compliance");
  for (int k = 0; k < 6; ++k) {
    const bool angle = k >= 3;
    const double scale = angle ? 1.0 / kDegree : 1e3;
    const double span = (last.y(k) - first.y(k)) * scale;
    const double per_kn =
        magnitude_span > 0 ? span / (magnitude_span / 1e3) : 0;
    std::printf("  %-8s %9.4f %-3s%9.4f %-3s%9.4f %s/kN\n", kChannelNames[k],
                first.y(k) * scale, angle ? "deg" : "mm", last.y(k) * scale,
                angle ? "deg" : "mm", per_kn, angle ? "deg" : "mm");
  }
  if (!args.out.empty()) {
    std::printf("  wrote %s and %s\n", args.out.c_str(),
                SidecarPath(args.out).c_str());
  }
}

int RunSimulate(const SimulateArgs& args) {
  const CommandError fail("simulate");
  KcrigConfig config;
  Status status = LoadConfig(args.config_dir, &config);
  if (!status.ok()) return fail(status);
  SimulatedRunOptions run_options;
  // The configured geometry: --set changes the simulated plant, not the
  // configuration the log is recorded with.
  run_options.geometry = GeometryFingerprint(config.model);
  for (const std::string& set : args.sets) {
    status = ApplyParameterAssignment("--set", set, &config.model);
    if (!status.ok()) return fail(status);
  }
  status = ValidateModel(config.model, "--set");
  if (!status.ok()) return fail(status);
  for (const std::string& effect : args.effects) {
    status = ParseEffect(effect, &run_options.effects);
    if (!status.ok())
      return fail(Status::Error("--effect " + status.message()));
  }

  RampExcitation<double> excitation;
  double rate = 0;
  status = ResolveExcitation(args, config.experiment, &excitation, &rate);
  if (!status.ok()) return fail(status);

  if (args.plant_step &&
      !(*args.plant_step > 0 && *args.plant_step <= config.experiment.step)) {
    return fail(
        Status::Error("--plant-step: must be within (0, integrator.step = " +
                      std::to_string(config.experiment.step) + " s]"));
  }
  run_options.rate = rate;
  run_options.step = args.plant_step.value_or(0);
  run_options.noise = args.noise;
  run_options.seed = args.seed;
  RunLog log;
  status = SimulateRun(config.model, excitation, config.experiment, run_options,
                       &log);
  if (!status.ok()) return fail(status);
  if (!args.out.empty()) {
    status = WriteRunLog(args.out, log);
    if (!status.ok()) return fail(status);
  }
  PrintSummary(args, log, excitation);
  return 0;
}

}  // namespace

void AddSimulateCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* cmd = app->add_subcommand(
      "simulate",
      "Run the suspension model for one ramp excitation and write a run log");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  AddExcitationOptions(cmd, &args->excitation);
  cmd->add_option_function<double>(
      "--rate", [args](const double& rate) { args->rate = rate; },
      "Sample rate [Hz]");
  cmd->add_option_function<double>(
      "--plant-step", [args](const double& step) { args->plant_step = step; },
      "Integration step of the simulated plant [s] (default: the "
      "model's integrator.step; finer is closer to a continuous rig, as the "
      "emulator's rig.step)");
  cmd->add_option("--set", args->sets,
                  "Override a model parameter, NAME=VALUE in SI (repeatable)");
  cmd->add_flag("--noise", args->noise,
                "Add Gaussian sensor noise (config sigmas)");
  cmd->add_option("--seed", args->seed, "Noise seed");
  cmd->add_option(
      "--effect", args->effects,
      "Unmodelled effect of the true plant, NAME[:k=v,...] "
      "(repeatable; bushing_damping, hysteresis, "
      "progressive_stiffness, actuator_lag, rig_compliance, "
      "sensor_offset; parameters in rt_core/model/plant_effects.h)");
  cmd->add_option("--out", args->out,
                  "Run log to write (run.csv; the sidecar run.json beside it)");
  cmd->callback([args, run] { *run = [args] { return RunSimulate(*args); }; });
}

}  // namespace kcrig
