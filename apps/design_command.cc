#include "apps/design_command.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "apps/cli_util.h"
#include "apps/progress.h"
#include "base/atomic_files.h"
#include "cluster/ranks.h"
#include "designer/design_io.h"
#include "designer/design_step.h"
#include "designer/isolating_design.h"
#include "estimator/estimate_io.h"
#include "records/run_log.h"
#include "rt_core/model/channels.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

struct DesignArgs {
  std::string config_dir;
  std::string estimate;
  bool augment = false;
  std::string criterion = "D";
  std::string optimizers = "kriging";
  std::optional<int> budget;
  std::optional<double> start_phi_deg, start_z;
  std::string grid = "46x26";
  std::string kriging_trend = "quadratic";
  bool no_expected_improvement = false;
  bool quiet = false;
  std::string out;
  // --isolate: the ramp that tells apart the faults the plan cannot.
  bool isolate = false;
  std::vector<std::string> logs, ramps;
  std::string candidates;
  double min_share = 0.2;
  // Options of the one mode given with the other (names, for the error).
  std::string criterion_options_given, isolate_options_given;
};

Status ParseGrid(const std::string& text, OptimizerOptions* options) {
  int phi = 0, z = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &phi, &x, &z, &extra) != 3 ||
      x != 'x' || phi < 2 || z < 2 || phi > 2000 || z > 2000) {
    return Status::Error(
        "--grid " + text +
        ": expected PHIxZ points, e.g. 46x26 (2 .. 2000 each)");
  }
  options->grid_phi_points = phi;
  options->grid_z_points = z;
  return Status::Ok();
}

// What every rank reads and checks alike before the search.
struct DesignInputs {
  KcrigConfig config;
  Criterion criterion;
  OptimizerOptions optimizer_options;
  std::vector<std::string> optimizers;
  EstimateFile estimate;
  DesignStepOptions step;
};

Status Prepare(const DesignArgs& args, DesignInputs* in) {
  Status status = LoadConfig(args.config_dir, &in->config);
  if (!status.ok()) return status;
  status = CheckOutput("--out", args.out, {args.estimate});
  if (!status.ok()) return status;
  status = ParseCriterion(args.criterion, &in->criterion);
  if (!status.ok()) return status;
  status = ParseGrid(args.grid, &in->optimizer_options);
  if (!status.ok()) return status;
  if (args.kriging_trend == "constant") {
    in->optimizer_options.kriging_regression = KrigingRegression::kConstant;
  } else if (args.kriging_trend == "linear") {
    in->optimizer_options.kriging_regression = KrigingRegression::kLinear;
  } else if (args.kriging_trend != "quadratic") {
    return Status::Error("--kriging-trend " + args.kriging_trend +
                         ": expected constant, linear or quadratic");
  }
  in->optimizer_options.kriging_expected_improvement =
      !args.no_expected_improvement;
  in->optimizers = SplitList(args.optimizers);
  if (in->optimizers.empty()) {
    return Status::Error("--optimizer: give at least one optimizer");
  }

  // The parameters and their current values: an estimate, or the config.
  if (!args.estimate.empty()) {
    status = ReadEstimateFile(args.estimate, &in->estimate);
    if (!status.ok()) return status;
    if (args.augment && in->estimate.information.size() == 0) {
      return Status::Error(args.estimate +
                           ": --augment needs an information_matrix "
                           "(written by kcrig estimate)");
    }
  } else {
    if (args.augment) {
      return Status::Error("--augment: needs --estimate est.json");
    }
    in->estimate.names = EstimatorOptions().parameters;
    std::vector<int> indices;
    status = ResolveParameters(in->config.model, in->estimate.names, &indices);
    if (!status.ok()) return status;
    in->estimate.values = ParameterValues(in->config.model, indices);
  }
  in->step.names = in->estimate.names;
  in->step.values = in->estimate.values;
  if (args.augment) in->step.prior_information = in->estimate.information;
  in->step.criterion = in->criterion;
  in->step.optimizer_options = in->optimizer_options;
  // Under mpirun the batches spread over the ranks.
  in->step.objective.batches = &WorldBatches();
  in->step.objective.num_threads = ThreadsPerRank(WorldRanks());
  return Status::Ok();
}

// --isolate (designer/isolating_design.h): the plan's ties and the ramp
// that resolves the most of them.
int RunIsolatingDesign(const DesignArgs& args) {
  const StopSignal stop;
  const CommandError fail("design");
  if (WorldRanks().size() > 1) {
    return fail(Status::Error(
        "--isolate runs in one process: start it without mpirun"));
  }
  if (!args.criterion_options_given.empty()) {
    return fail(Status::Error(
        "--isolate designs for the ties of the plan (--log, --ramp), not "
        "for a criterion: drop " +
        args.criterion_options_given));
  }
  KcrigConfig config;
  std::vector<Experiment> plan;
  Status status = LoadPlanInputs(args.config_dir, args.out, args.logs,
                                 args.ramps, &config, &plan);
  if (!status.ok()) return fail(status);
  IsolatingDesignOptions options;
  options.isolability.candidates = SplitList(args.candidates);
  options.isolability.min_share_left = args.min_share;
  if (args.budget) {
    options.search.evaluations_per_shape = std::max(
        1, *args.budget / static_cast<int>(options.search.shapes.size()));
  }
  IsolatingDesign design;
  {
    ProgressLine line(args.quiet);
    options.isolability.callback =
        stop.Callback([&line](const IterationSummary& s) {
          line.Show("kcrig design: " + s.stage, s.fraction);
        });
    status = DesignIsolatingExperiment(config, plan, options, &design);
  }
  if (stop.received()) return stop.Exit("design");
  if (!status.ok()) return fail(status);
  if (!args.out.empty()) {
    status = WriteFilesAtomically({{args.out, IsolatingDesignToJson(design)}});
    if (!status.ok()) return fail(status);
  }
  std::printf(
      "kcrig design --isolate: %zu experiment%s in the plan, %zu "
      "tie%s\n",
      plan.size(), plan.size() == 1 ? "" : "s", design.ties.size(),
      design.ties.size() == 1 ? "" : "s");
  if (design.ties.empty()) {
    std::printf(
        "  the plan tells every pair of candidates apart: nothing "
        "to design\n");
  } else {
    const RampExcitation<double>& d = design.excitation;
    std::printf(
        "  next experiment: phi %.2f deg, z_a %.3f m, ramp %.2f s, hold "
        "%.2f s, return %.2f s (kcrig run %s)\n"
        "  resolves %d of the %zu ties; their mean separation %.0f %% -> "
        "%.0f %%, smallest %.0f %% -> %.0f %% (%d evaluations)\n",
        d.phi / kDegree, d.z_a, d.duration, d.hold, d.return_duration,
        RunOptions(d).c_str(), design.resolved, design.ties.size(),
        100 * design.mean_before, 100 * design.mean_after,
        100 * design.smallest_before, 100 * design.smallest_after,
        design.evaluations);
  }
  if (!args.out.empty()) std::printf("  wrote %s\n", args.out.c_str());
  return 0;
}

int RunDesign(const DesignArgs& args) {
  if (args.isolate) return RunIsolatingDesign(args);
  const StopSignal stop;
  const CommandError fail("design");
  if (!args.isolate_options_given.empty()) {
    return fail(
        Status::Error(args.isolate_options_given + ": only with --isolate"));
  }
  // Rank 0 alone reads the inputs; the other ranks their copies.
  InputMirror mirror(WorldRanks());
  DesignArgs read = args;
  Status status = MirrorConfig(&mirror, &read.config_dir);
  if (status.ok()) status = mirror.Mirror(&read.estimate);
  DesignInputs in;
  if (status.ok()) status = Prepare(read, &in);
  status = WorldRanks().Agree(status);
  if (!status.ok()) return fail(status);
  const KcrigConfig& config = in.config;
  const Criterion criterion = in.criterion;
  const OptimizerOptions& optimizer_options = in.optimizer_options;
  const EstimateFile& estimate = in.estimate;
  DesignStepOptions& step = in.step;

  const DesignBounds bounds{config.experiment.phi_bounds,
                            config.experiment.z_a_bounds};
  const Design start{args.start_phi_deg ? *args.start_phi_deg * kDegree
                                        : config.experiment.phi,
                     args.start_z.value_or(config.experiment.z_a)};
  ProgressLine progress(args.quiet);
  std::vector<DesignRun> runs;
  for (const std::string& optimizer : in.optimizers) {
    const int grid_points =
        optimizer_options.grid_phi_points * optimizer_options.grid_z_points + 1;
    step.optimizer = optimizer;
    step.objective.budget =
        args.budget.value_or(optimizer == "grid" ? grid_points : 100);
    step.objective.callback =
        stop.Callback([&progress, &optimizer](const IterationSummary& s) {
          progress.Show(optimizer + ": " + s.stage);
        });
    DesignRun run;
    status = DesignStep(config, step, start, &run);
    if (stop.received()) {
      progress.Clear();
      return stop.Exit("design");
    }
    if (!status.ok()) return fail(status);
    runs.push_back(std::move(run));
  }
  progress.Clear();

  if (!args.out.empty() && WorldRanks().is_root()) {
    status =
        WriteFilesAtomically({{args.out, DesignRunsToJson(criterion, runs)}});
    if (!status.ok()) return fail(status);
  }
  std::printf(
      "kcrig design: criterion %s for %zu parameters at the %s%s; bounds phi "
      "%.0f..%.0f deg, z_a %.2f..%.2f m\n",
      CriterionName(criterion), estimate.names.size(),
      args.estimate.empty() ? "config values" : "estimate",
      args.augment ? ", added to its data" : "", bounds.phi.lower / kDegree,
      bounds.phi.upper / kDegree, bounds.z_a.lower, bounds.z_a.upper);
  std::printf("%s", ComparisonTable(criterion, runs).c_str());
  const DesignRun* best = &runs[BestRun(runs)];
  std::printf("  optimal design: phi %.2f deg, z_a %.3f m (%s)%s\n",
              best->result.best.phi / kDegree, best->result.best.z_a,
              best->result.optimizer.c_str(),
              best->result.best_singular
                  ? "; WARNING: the information matrix is singular there"
                  : "");
  if (!args.out.empty()) std::printf("  wrote %s\n", args.out.c_str());
  return 0;
}

}  // namespace

void AddDesignCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<DesignArgs>();
  CLI::App* cmd = app->add_subcommand(
      "design",
      "Optimal experimental design of the next ramp (phi, z_a) for the D, A, "
      "E or MM criterion");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--estimate", args->estimate,
                  "est.json: design at these parameter values (default: the "
                  "config's five bushing stiffnesses)");
  cmd->add_flag("--augment", args->augment,
                "Design the experiment to add to the data behind --estimate "
                "(its J^T J is the prior information)");
  cmd->add_option("--criterion", args->criterion, "D, A, E or MM")
      ->capture_default_str();
  cmd->add_option("--optimizer", args->optimizers,
                  "imfil, kriging, nlopt:direct-l|crs2|bobyqa|cobyla|slsqp|"
                  "mma, grid; a comma list compares them in a table")
      ->capture_default_str();
  cmd->add_option_function<int>(
      "--budget", [args](const int& n) { args->budget = n; },
      "Most criterion evaluations per optimizer (default 100; grid: all "
      "points)");
  cmd->add_option_function<double>(
      "--start-phi", [args](const double& v) { args->start_phi_deg = v; },
      "Start design phi [deg] (default: experiment.yaml)");
  cmd->add_option_function<double>(
      "--start-z", [args](const double& v) { args->start_z = v; },
      "Start design z_a [m] (default: experiment.yaml)");
  cmd->add_option("--grid", args->grid,
                  "Grid points PHIxZ for --optimizer grid")
      ->capture_default_str();
  cmd->add_option("--kriging-trend", args->kriging_trend,
                  "Regression trend of the kriging surrogate: constant, "
                  "linear or quadratic")
      ->capture_default_str();
  cmd->add_flag("--no-expected-improvement", args->no_expected_improvement,
                "Kriging refines only at the surrogate's minimum");
  cmd->add_flag("--quiet", args->quiet, "No progress line");
  cmd->add_option("--out", args->out, "design.json to write");
  cmd->add_flag("--isolate", args->isolate,
                "Design the ramp that tells apart the faults the plan "
                "(--log, --ramp) cannot (kcrig isolability), instead of "
                "the criterion's");
  cmd->add_option("--log", args->logs,
                  "With --isolate: a logged experiment of the plan "
                  "(repeatable)");
  cmd->add_option("--ramp", args->ramps,
                  "With --isolate: " + std::string(kRampHelp));
  cmd->add_option("--candidates", args->candidates,
                  "With --isolate: comma-separated candidates (default: "
                  "every effect on each component, every freeable model "
                  "parameter)");
  cmd->add_option("--min-share", args->min_share,
                  "With --isolate: share of a fault's signature its rival "
                  "must leave for the diagnosis to tell them apart")
      ->check(CLI::Range(0.001, 0.999));
  cmd->callback([cmd, args, run] {
    auto given = [cmd](std::initializer_list<const char*> names) {
      std::string list;
      for (const char* name : names) {
        if (cmd->count(name) > 0)
          list += (list.empty() ? "" : ", ") + std::string(name);
      }
      return list;
    };
    args->criterion_options_given =
        given({"--estimate", "--augment", "--criterion", "--optimizer",
               "--start-phi", "--start-z", "--grid", "--kriging-trend",
               "--no-expected-improvement"});
    args->isolate_options_given =
        given({"--log", "--ramp", "--candidates", "--min-share"});
    *run = [args] { return RunDesign(*args); };
  });
}

}  // namespace kcrig
