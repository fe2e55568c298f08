#include "apps/screen_command.h"

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "apps/cli_util.h"
#include "apps/progress.h"
#include "base/atomic_files.h"
#include "estimator/screening.h"
#include "nlohmann/json.hpp"
#include "records/run_log.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

struct ScreenArgs {
  std::string config_dir;
  std::vector<std::string> logs;
  std::string params;
  std::string channels;
  double range_low = 0.5;
  double range_high = 2.0;
  int trajectories = 20;
  int levels = 4;
  std::uint64_t seed = 1;
  std::string out;
  bool quiet = false;
};

std::string ToJson(const ScreeningResult& r,
                   const std::vector<std::string>& logs) {
  nlohmann::ordered_json doc;
  doc["format"] = "kcrig screen 1";
  doc["logs"] = logs;
  nlohmann::ordered_json ranking = nlohmann::ordered_json::array();
  int rank = 1;
  for (const ScreenedParameter& p : r.ranking) {
    ranking.push_back({{"rank", rank++},
                       {"name", p.name},
                       {"mu_star", p.mu_star},
                       {"mu", p.mu},
                       {"sigma", p.sigma},
                       {"negligible", p.negligible}});
  }
  doc["ranking"] = ranking;
  doc["names"] = r.names;
  std::vector<std::vector<double>> correlation(
      r.names.size(), std::vector<double>(r.names.size()));
  for (size_t i = 0; i < r.names.size(); ++i) {
    for (size_t j = 0; j < r.names.size(); ++j) {
      correlation[i][j] = r.sensitivity_correlation(i, j);
    }
  }
  doc["sensitivity_correlation"] = correlation;
  nlohmann::ordered_json pairs = nlohmann::ordered_json::array();
  for (const auto& [a, b] : r.dependent_pairs) pairs.push_back({a, b});
  doc["dependent_pairs"] = pairs;
  doc["estimable"] = r.estimable;
  doc["evaluations"] = r.evaluations;
  doc["seconds"] = r.seconds;
  return doc.dump(2) + "\n";
}

int RunScreen(const ScreenArgs& args) {
  const StopSignal stop;
  const CommandError fail("screen");
  KcrigConfig config;
  Status status = LoadConfig(args.config_dir, &config);
  if (!status.ok()) return fail(status);
  status = CheckOutput("--out", args.out, args.logs);
  if (!status.ok()) return fail(status);
  EstimatorOptions estimator_options;
  if (!args.channels.empty()) {
    status = ParseChannels(args.channels, &estimator_options.channels);
    if (!status.ok()) return fail(status);
  }
  ScreeningOptions options;
  if (!args.params.empty()) options.parameters = SplitList(args.params);
  options.range_low = args.range_low;
  options.range_high = args.range_high;
  options.trajectories = args.trajectories;
  options.levels = args.levels;
  options.seed = args.seed;
  std::vector<Experiment> experiments;
  status = LoadLogs(args.logs, config, &experiments);
  if (!status.ok()) return fail(status);
  ScreeningResult result;
  {
    ProgressLine line(args.quiet);
    options.callback = stop.Callback([&line](const IterationSummary& s) {
      line.Show("kcrig screen: " + std::to_string(s.done) + "/" +
                    std::to_string(s.total) + " model evaluations",
                s.fraction);
    });
    status = Screen(config.model, experiments, estimator_options, options,
                    config.experiment.step, &result);
  }
  if (stop.received()) return stop.Exit("screen");
  if (!status.ok()) return fail(status);
  if (!args.out.empty()) {
    status = WriteFilesAtomically({{args.out, ToJson(result, args.logs)}});
    if (!status.ok()) return fail(status);
  }
  std::printf(
      "kcrig screen: %zu candidates over [%.2f, %.2f] x nominal, %d "
      "evaluations (%.2f s)\n  rank %-10s %12s %12s\n",
      result.names.size(), options.range_low, options.range_high,
      result.evaluations, result.seconds, "parameter", "mu*", "sigma");
  int rank = 1;
  for (const ScreenedParameter& p : result.ranking) {
    std::printf("  %4d %-10s %12.4g %12.4g%s\n", rank++, p.name.c_str(),
                p.mu_star, p.sigma, p.negligible ? "  negligible" : "");
  }
  for (const auto& [a, b] : result.dependent_pairs) {
    std::printf("  mutually dependent: %s and %s\n", a.c_str(), b.c_str());
  }
  std::printf("  proposed estimable subset:");
  for (const std::string& name : result.estimable)
    std::printf(" %s", name.c_str());
  std::printf("\n");
  if (!args.out.empty()) std::printf("  wrote %s\n", args.out.c_str());
  return 0;
}

}  // namespace

void AddScreenCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<ScreenArgs>();
  CLI::App* cmd = app->add_subcommand(
      "screen",
      "Rank candidate parameters by their impact on the fit objective "
      "(Morris screening), flag dependent pairs, propose the estimable set");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--log", args->logs, "Reference run log (repeatable)")
      ->required();
  cmd->add_option("--params", args->params,
                  "Comma-separated candidates (default: the five stiffnesses)");
  cmd->add_option("--channels", args->channels,
                  "Comma-separated channels in the objective (default: all)");
  cmd->add_option("--range-low", args->range_low,
                  "Lower end of every range, x nominal");
  cmd->add_option("--range-high", args->range_high,
                  "Upper end of every range, x nominal");
  cmd->add_option("--trajectories", args->trajectories, "Morris trajectories")
      ->check(CLI::Range(1, 10000));
  cmd->add_option("--levels", args->levels, "Grid levels per parameter")
      ->check(CLI::Range(2, 1000));
  cmd->add_option("--seed", args->seed, "Seed of the Morris design");
  cmd->add_option("--out", args->out, "screen.json to write");
  cmd->add_flag("--quiet", args->quiet, "No progress line");
  cmd->callback([args, run] { *run = [args] { return RunScreen(*args); }; });
}

}  // namespace kcrig
