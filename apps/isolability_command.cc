#include "apps/isolability_command.h"

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "apps/cli_util.h"
#include "apps/progress.h"
#include "base/atomic_files.h"
#include "diagnosis/isolability.h"
#include "records/run_log.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

struct IsolabilityArgs {
  std::string config_dir;
  std::vector<std::string> logs;
  std::vector<std::string> ramps;
  std::string candidates;
  double min_share = 0.2;
  int threads = kDefaultThreads;
  std::string out;
  bool quiet = false;
};

int RunIsolability(const IsolabilityArgs& args) {
  const StopSignal stop;
  const CommandError fail("isolability");
  KcrigConfig config;
  std::vector<Experiment> plan;
  Status status = LoadPlanInputs(args.config_dir, args.out, args.logs,
                                 args.ramps, &config, &plan);
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
  cmd->add_option("--ramp", args->ramps, kRampHelp);
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
