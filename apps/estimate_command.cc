#include "apps/estimate_command.h"

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "apps/cli_util.h"
#include "apps/progress.h"
#include "base/atomic_files.h"
#include "estimator/estimate_io.h"
#include "estimator/estimator.h"
#include "estimator/profile_likelihood.h"
#include "records/run_log.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

struct EstimateArgs {
  std::string config_dir;
  std::vector<std::string> logs;
  std::vector<std::string> holdout;
  std::string params;
  std::string channels;
  double init_scale = 1.0;
  std::vector<std::string> inits;
  bool profile = false;
  std::string out;
};

int RunEstimate(const EstimateArgs& args) {
  const StopSignal stop;
  const CommandError fail("estimate");
  KcrigConfig config;
  Status status = LoadConfig(args.config_dir, &config);
  if (!status.ok()) return fail(status);
  std::vector<std::string> inputs = args.logs;
  inputs.insert(inputs.end(), args.holdout.begin(), args.holdout.end());
  status = CheckOutput("--out", args.out, inputs);
  if (!status.ok()) return fail(status);

  EstimatorOptions options;
  options.callback = stop.Callback();
  if (!args.params.empty()) options.parameters = SplitList(args.params);
  if (!args.channels.empty()) {
    status = ParseChannels(args.channels, &options.channels);
    if (!status.ok()) return fail(status);
  }
  std::vector<int> indices;
  status = ResolveParameters(config.model, options.parameters, &indices);
  if (!status.ok()) return fail(Status::Error("--params: " + status.message()));
  if (!(args.init_scale > 0)) {
    return fail(Status::Error("--init-scale: must be > 0"));
  }
  std::vector<double> initial = ParameterValues(config.model, indices);
  for (double& value : initial) value *= args.init_scale;
  for (const std::string& init : args.inits) {
    std::string name;
    double value = 0;
    status = ParseAssignment("--init", init, &name, &value);
    if (!status.ok()) return fail(status);
    bool matched = false;
    for (size_t i = 0; i < indices.size(); ++i) {
      if (options.parameters[i] == name) {
        initial[i] = value;
        matched = true;
      }
    }
    if (!matched) {
      return fail(Status::Error("--init " + init + ": '" + name +
                                "' is not among the estimated parameters"));
    }
  }

  std::vector<Experiment> experiments, holdout;
  status = LoadLogs(args.logs, config, &experiments);
  if (status.ok()) status = LoadLogs(args.holdout, config, &holdout);
  if (status.ok()) status = CheckSameForceChannels(experiments, holdout);
  if (!status.ok()) return fail(status);
  EstimationResult result;
  status = Estimate(config.model, experiments, options, initial,
                    config.experiment.step, &result);
  if (stop.received()) return stop.Exit("estimate");
  if (!status.ok()) return fail(status);
  HoldoutPrediction prediction;
  if (!holdout.empty()) {
    prediction.logs = args.holdout;
    status = PredictExperiments(config.model, holdout, options, result,
                                config.experiment.step, &prediction.adequacy);
    if (!status.ok()) return fail(status);
  }
  std::vector<ParameterProfile> profiles;
  if (args.profile) {
    status =
        ProfileLikelihood(config.model, experiments, options, result,
                          config.experiment.step, ProfileOptions{}, &profiles);
    if (stop.received()) return stop.Exit("estimate");
    if (!status.ok()) return fail(status);
  }
  if (!args.out.empty()) {
    status = WriteFilesAtomically(
        {{args.out,
          EstimationResultToJson(result, args.logs, profiles, prediction)}});
    if (!status.ok()) return fail(status);
  }
  std::fputs(EstimationSummary(result, args.logs, profiles, prediction).c_str(),
             stdout);
  if (!args.out.empty()) std::printf("  wrote %s\n", args.out.c_str());
  return 0;
}

}  // namespace

void AddEstimateCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<EstimateArgs>();
  CLI::App* cmd = app->add_subcommand(
      "estimate", "Fit model parameters to run logs (Levenberg-Marquardt)");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--log", args->logs,
                  "Run log run.csv (repeatable: experiments fitted jointly)")
      ->required();
  cmd->add_option("--holdout", args->holdout,
                  "Run log not fitted but predicted with the estimate "
                  "(repeatable): its prediction score per channel and tail "
                  "probability");
  cmd->add_option("--params", args->params,
                  "Comma-separated parameters to estimate (default: "
                  "c_O1,c_O2,c_V1,c_V2,c_P)");
  cmd->add_option("--channels", args->channels,
                  "Comma-separated channels in the fit (default: all of "
                  "x,y,z,toe,camber,caster)");
  cmd->add_option("--init-scale", args->init_scale,
                  "Start every parameter at this multiple of its config value");
  cmd->add_option("--init", args->inits,
                  "Start value NAME=VALUE in SI (repeatable)");
  cmd->add_flag("--profile", args->profile,
                "Also compute the profile likelihood of every parameter "
                "(re-optimizing the others; slower)");
  cmd->add_option("--out", args->out, "est.json to write");
  cmd->callback([args, run] { *run = [args] { return RunEstimate(*args); }; });
}

}  // namespace kcrig
