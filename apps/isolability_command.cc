#include "apps/isolability_command.h"

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "apps/cli_util.h"
#include "apps/progress.h"
#include "diagnosis/isolability.h"
#include "records/run_log.h"
#include "rt_core/model/channels.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

struct IsolabilityArgs {
  std::string config_dir;
  std::vector<std::string> logs;
  std::vector<std::string> designs;
  std::string candidates;
  double min_share = 0.2;
  int threads = 2;
  std::string out;
  bool quiet = false;
};

// "PHI_DEG,Z_M[,TF_S[,HOLD_S[,RETURN_S]]]": a planned ramp with the
// config's Fmax, within the config's design bounds.
Status ParseDesign(const std::string& text, const ExperimentConfig& config,
                   RampExcitation<double>* ramp) {
  const std::vector<std::string> items = SplitList(text);
  const std::string where = "--design '" + text + "': ";
  if (items.size() < 2 || items.size() > 5) {
    return Status::Error(where +
                         "expected PHI_DEG,Z_M[,TF_S[,HOLD_S[,RETURN_S]]]");
  }
  double v[5] = {0, 0, config.duration, 0, 0};
  for (size_t k = 0; k < items.size(); ++k) {
    if (!ParseFiniteDouble(items[k], &v[k])) {
      return Status::Error(where + "'" + items[k] + "' is not a number");
    }
  }
  const double phi = v[0] * kDegree;
  if (phi < config.phi_bounds.lower - 1e-12 ||
      phi > config.phi_bounds.upper + 1e-12 ||
      v[1] < config.z_a_bounds.lower - 1e-12 ||
      v[1] > config.z_a_bounds.upper + 1e-12) {
    return Status::Error(where +
                         "outside the design bounds of experiment.yaml");
  }
  if (!(v[2] > 0) || v[3] < 0 || v[4] < 0) {
    return Status::Error(where +
                         "the ramp time must be positive, hold and "
                         "return not negative");
  }
  *ramp = {phi, v[1], config.fmax, v[2], v[3], v[4]};
  return Status::Ok();
}

// The logs, then the planned designs; the config's own experiment when
// neither is given.
Status PlanOf(const IsolabilityArgs& args, const KcrigConfig& config,
              std::vector<Experiment>* plan) {
  KCRIG_RETURN_IF_ERROR(LoadLogs(args.logs, config, plan));
  for (const std::string& text : args.designs) {
    RampExcitation<double> ramp;
    KCRIG_RETURN_IF_ERROR(ParseDesign(text, config.experiment, &ramp));
    plan->push_back(PlannedExperiment(ramp, config.experiment));
  }
  if (plan->empty()) {
    const ExperimentConfig& e = config.experiment;
    plan->push_back(PlannedExperiment(e.Excitation(e.phi, e.z_a), e));
  }
  return Status::Ok();
}

int RunIsolability(const IsolabilityArgs& args) {
  const StopSignal stop;
  auto fail = [](const Status& status) {
    std::fprintf(stderr, "kcrig isolability: %s\n", status.message().c_str());
    return 1;
  };
  KcrigConfig config;
  Status status = LoadConfig(args.config_dir, &config);
  if (status.ok()) status = CheckOutput("--out", args.out, args.logs);
  std::vector<Experiment> plan;
  if (status.ok()) status = PlanOf(args, config, &plan);
  if (!status.ok()) return fail(status);
  IsolabilityOptions options;
  options.candidates = SplitList(args.candidates);
  options.min_share_left = args.min_share;
  options.num_threads = args.threads;
  Isolability result;
  {
    ProgressLine line(args.quiet);
    options.callback = stop.Callback([&line](const IterationSummary& s) {
      line.Show("kcrig " + s.stage, s.fraction);
    });
    status = ComputeIsolability(config.model, plan, config.experiment.step,
                                options, &result);
  }
  if (stop.received()) return stop.Exit("isolability");
  if (!status.ok()) return fail(status);
  if (!args.out.empty()) {
    status =
        WriteFilesAtomically({{args.out, IsolabilityToJson(result) + "\n"}});
    if (!status.ok()) return fail(status);
  }
  std::printf("kcrig isolability: %zu experiment%s; %s", plan.size(),
              plan.size() == 1 ? "" : "s", IsolabilitySummary(result).c_str());
  if (!args.out.empty()) std::printf("  wrote %s\n", args.out.c_str());
  return 0;
}

}  // namespace

void AddIsolabilityCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<IsolabilityArgs>();
  CLI::App* cmd = app->add_subcommand(
      "isolability",
      "Which faults (an effect on one component, a wrong model parameter) "
      "a plan of experiments can tell apart, before it is run");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--log", args->logs, "Logged experiment (repeatable)");
  cmd->add_option("--design", args->designs,
                  "Planned ramp PHI_DEG,Z_M[,TF_S[,HOLD_S[,RETURN_S]]] with "
                  "the config's Fmax (repeatable; none and no --log: the "
                  "config's experiment)");
  cmd->add_option("--candidates", args->candidates,
                  "Comma-separated candidates (default: every effect on "
                  "each component, every freeable model parameter)");
  cmd->add_option("--min-share", args->min_share,
                  "Share of a fault's signature its rival must leave for the "
                  "diagnosis to tell them apart")
      ->check(CLI::Range(0.001, 0.999));
  cmd->add_option("--threads", args->threads, "Threads")
      ->check(CLI::Range(1, 256));
  cmd->add_option("--out", args->out, "isolability.json to write");
  cmd->add_flag("--quiet", args->quiet, "No progress line");
  cmd->callback(
      [args, run] { *run = [args] { return RunIsolability(*args); }; });
}

}  // namespace kcrig
