#include "apps/validate_command.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "apps/cli_util.h"
#include "apps/progress.h"
#include "base/atomic_files.h"
#include "cluster/ranks.h"
#include "records/batch_checkpoint.h"
#include "records/run_log.h"
#include "validation/validation.h"

namespace kcrig {
namespace {

struct ValidateArgs {
  std::string config_dir;
  int cases = 40;
  std::string effects;
  std::string plan;
  std::uint64_t seed = 1;
  std::optional<int> threads;
  bool quiet = false;
  bool resume = false;
  std::string out;
  std::string timings;
};

constexpr int kMaxCases = 1000000;

// Where validate keeps its completed cases while it runs: beside --out.
std::string CheckpointFolder(const std::string& out) {
  return out + ".checkpoint";
}

// --out, its checkpoint folder and --timings: writable, none of the inputs,
// no two the same file.
Status CheckOutputs(const ValidateArgs& args,
                    const std::vector<std::string>& inputs) {
  KCRIG_RETURN_IF_ERROR(CheckOutput("--out", args.out, inputs));
  KCRIG_RETURN_IF_ERROR(CheckOutput("--timings", args.timings, inputs));
  if (args.timings.empty() || args.out.empty()) return Status::Ok();
  const auto same = [](const std::string& a, const std::string& b) {
    std::error_code error_a, error_b;
    const auto path_a = std::filesystem::weakly_canonical(a, error_a);
    const auto path_b = std::filesystem::weakly_canonical(b, error_b);
    return error_a || error_b ? a == b : path_a == path_b;
  };
  if (same(args.timings, args.out) ||
      same(args.timings, CheckpointFolder(args.out))) {
    return Status::Error("--timings: names --out or its checkpoint folder");
  }
  return Status::Ok();
}

// Every rank checks what it was given alike; the root alone its output.
Status Prepare(const ValidateArgs& args, const Ranks& ranks,
               KcrigConfig* config, ValidationOptions* options) {
  Status status = LoadConfig(args.config_dir, config);
  if (!status.ok()) return status;
  if (args.cases < 1 || args.cases > kMaxCases) {
    return Status::Error("--cases: must be within [1, " +
                         std::to_string(kMaxCases) + "]");
  }
  if (args.resume && args.out.empty()) {
    return Status::Error("--resume: needs --out (the checkpoint is beside it)");
  }
  options->cases = args.cases;
  options->seed = args.seed;
  if (!args.effects.empty()) options->classes = SplitList(args.effects);
  if (!args.plan.empty()) {
    status = LoadBlindTestPlan(args.plan, &options->plan);
    if (!status.ok()) return status;
  }
  BlindCase probe;
  status = DrawBlindCase(0, args.seed, config->model, options->classes,
                         options->plan, &probe);
  if (!status.ok()) return Status::Error("--effects: " + status.message());
  options->diagnosis.num_threads = ThreadsPerRank(ranks, args.threads);
  if (options->diagnosis.num_threads < 1) {
    return Status::Error("--threads: must be >= 1");
  }
  KCRIG_RETURN_IF_ERROR(LoadValidationRig(*config, args.plan, options));
  // Every drawn case's ramps within the rig's limits before any case runs
  // (a plan's were checked as it loaded).
  for (int i = 0; options->plan.training.empty() && i < options->cases; ++i) {
    BlindCase blind_case;
    KCRIG_RETURN_IF_ERROR(DrawBlindCase(i, args.seed, config->model,
                                        options->classes, options->plan,
                                        &blind_case));
    KCRIG_RETURN_IF_ERROR(CheckBlindCaseOnRig(*config, *options, blind_case));
  }
  std::vector<std::string> inputs;
  if (!args.plan.empty()) inputs.push_back(args.plan);
  return ranks.is_root() ? CheckOutputs(args, inputs) : Status::Ok();
}

// What a checkpoint must agree with to be resumed: everything that shapes
// the cases' outcomes (the config's and the plan's bytes, the options).
BatchCheckpoint::Identity CheckpointIdentity(const ValidateArgs& args,
                                             const KcrigConfig& config,
                                             const ValidationOptions& options) {
  std::string effects;
  for (const std::string& truth : options.classes) {
    effects += (effects.empty() ? "" : ",") + truth;
  }
  return {{"command", "validate"},
          {"config", InputDigest(config.directory)},
          {"plan", args.plan.empty() ? "" : InputDigest(args.plan)},
          {"effects", effects.empty() ? "(all)" : effects},
          {"seed", std::to_string(args.seed)},
          {"cases", std::to_string(args.cases)}};
}

// The cases of a run: the checkpoint's done, the others pending, each of
// the kind of its truth (cases of one truth cost alike).
struct CasePlan {
  std::vector<std::string> outcomes;
  std::vector<int> pending, kinds;
  std::vector<std::string> truths;
  std::vector<double> seconds;  // each case's wall time, once done
};

Status PlanCases(const KcrigConfig& config, const ValidationOptions& options,
                 const BatchCheckpoint& checkpoint, CasePlan* plan_out) {
  CasePlan& plan = *plan_out;
  plan.outcomes.resize(options.cases);
  plan.seconds.assign(options.cases, 0.0);
  std::map<std::string, int> kind_of;
  for (int i = 0; i < options.cases; ++i) {
    const auto kept = checkpoint.items().find(i);
    if (kept != checkpoint.items().end()) {
      plan.outcomes[i] = kept->second.result;
      plan.seconds[i] = kept->second.seconds;
    } else {
      plan.pending.push_back(i);
    }
    BlindCase blind_case;
    KCRIG_RETURN_IF_ERROR(DrawBlindCase(i, options.seed, config.model,
                                        options.classes, options.plan,
                                        &blind_case));
    plan.truths.push_back(blind_case.truth);
    plan.kinds.push_back(
        kind_of.emplace(blind_case.truth, kind_of.size()).first->second);
  }
  return Status::Ok();
}

// --timings: what each case cost (a scheduling study's input; kept out of
// validate.json, which is the same whatever the machine).
std::string TimingsCsv(const CasePlan& plan) {
  std::string csv = "case,truth,seconds\n";
  char line[128];
  for (size_t i = 0; i < plan.truths.size(); ++i) {
    std::snprintf(line, sizeof(line), "%zu,%s,%.3f\n", i,
                  plan.truths[i].c_str(), plan.seconds[i]);
    csv += line;
  }
  return csv;
}

// What a stopped validate leaves: the checkpoint to resume from.
std::string KeptCases(const BatchCheckpoint& checkpoint, int done) {
  if (checkpoint.folder().empty()) return "nothing written";
  return std::to_string(done) + " cases kept in " + checkpoint.folder() +
         " (--resume goes on from them)";
}

// The pending cases spread over the ranks, each kept in the checkpoint as
// it is done; a progress line on the root.
Status RunCases(const ValidateArgs& args, const KcrigConfig& config,
                const StopSignal& stop, ValidationOptions* options,
                BatchCheckpoint* checkpoint, CasePlan* plan,
                std::atomic<int>* done) {
  const Ranks& ranks = WorldRanks();
  ProgressLine line(args.quiet || !ranks.is_root());
  options->diagnosis.callback = stop.Callback([&](const IterationSummary& s) {
    line.Show("kcrig validate: " + std::to_string(done->load()) +
                  " cases done, " + s.stage,
              std::min(1.0, (*done + s.fraction) / options->cases));
  });
  const Status status = ranks.Distribute(
      plan->pending, plan->kinds, 1,
      [&](int i, std::string* outcome) {
        const Status run = RunValidationCase(config, *options, i, outcome);
        if (run.ok()) return run;
        return Status::Error("case " + std::to_string(i) + ": " +
                             run.message());
      },
      [&](int i, const std::string& outcome, double seconds) {
        plan->seconds[i] = seconds;
        const Status kept = args.out.empty()
                                ? Status::Ok()
                                : checkpoint->Record(i, outcome, seconds);
        if (kept.ok()) ++*done;
        return kept;
      },
      &plan->outcomes);
  options->diagnosis.callback = nullptr;  // it shows on `line`, now gone
  line.Clear();
  return status;
}

// The root's files and summary once every case is done.
int Finish(const ValidateArgs& args, const KcrigConfig& config,
           const ValidationOptions& options, const CasePlan& plan,
           BatchCheckpoint* checkpoint) {
  const std::string json = ValidationToJson(config, options, plan.outcomes);
  std::vector<std::pair<std::string, std::string>> files;
  if (!args.out.empty()) files.emplace_back(args.out, json);
  if (!args.timings.empty()) files.emplace_back(args.timings, TimingsCsv(plan));
  Status status = WriteFilesAtomically(files);
  if (!status.ok()) {
    std::fprintf(stderr, "kcrig validate: %s; %s\n", status.message().c_str(),
                 KeptCases(*checkpoint, options.cases).c_str());
    return 1;
  }
  status = checkpoint->Remove();
  if (!status.ok()) {
    std::fprintf(stderr, "kcrig validate: %s\n", status.message().c_str());
    return 1;
  }
  std::fputs(ValidationSummary(json).c_str(), stdout);
  std::printf("  %d cases on %d rank%s", options.cases, WorldRanks().size(),
              WorldRanks().size() > 1 ? "s" : "");
  for (const auto& file : files) std::printf(", wrote %s", file.first.c_str());
  std::printf("\n");
  return 0;
}

int RunValidate(const ValidateArgs& args) {
  const Ranks& ranks = WorldRanks();
  const StopSignal stop;
  BatchCheckpoint checkpoint;
  std::atomic<int> done{0};
  // The error says which cases a checkpoint kept (rank 0 alone prints).
  auto fail = [&](const Status& status) {
    if (!ranks.is_root()) return 1;
    return CommandError("validate")(
        done == 0 ? status
                  : Status::Error(status.message() + "; " +
                                  KeptCases(checkpoint, done)));
  };
  // Rank 0 alone reads the inputs; the other ranks their copies.
  InputMirror mirror(ranks);
  ValidateArgs read = args;
  Status status = MirrorConfig(&mirror, &read.config_dir);
  if (status.ok()) status = mirror.Mirror(&read.plan);
  KcrigConfig config;
  ValidationOptions options;
  if (status.ok()) status = Prepare(read, ranks, &config, &options);
  status = ranks.Agree(status);
  // The root keeps each case as it is done (beside --out) and resumes.
  if (status.ok() && ranks.is_root() && !args.out.empty()) {
    status = checkpoint.Open(CheckpointFolder(args.out),
                             CheckpointIdentity(args, config, options),
                             options.cases, args.resume);
  }
  CasePlan plan;
  if (status.ok()) status = PlanCases(config, options, checkpoint, &plan);
  status = ranks.Agree(status);
  if (!status.ok()) return fail(status);
  done = options.cases - static_cast<int>(plan.pending.size());
  status = RunCases(args, config, stop, &options, &checkpoint, &plan, &done);
  if (stop.received()) {
    return ranks.is_root() ? stop.Exit("validate", KeptCases(checkpoint, done))
                           : 1;
  }
  if (!status.ok()) return fail(status);
  if (!ranks.is_root()) return 0;
  return Finish(args, config, options, plan, &checkpoint);
}

}  // namespace

void AddValidateCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<ValidateArgs>();
  CLI::App* cmd = app->add_subcommand(
      "validate",
      "How well kcrig diagnoses this configuration: blind cases run on the "
      "embedded SIL rig, diagnosed and scored against their truth (spread "
      "over MPI ranks under mpirun)");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--cases", args->cases, "Blind cases to draw (default 40)");
  cmd->add_option("--effects", args->effects,
                  "Comma-separated truths to cycle through (default: the six "
                  "library effects, none, model_parameter)");
  cmd->add_option("--plan", args->plan,
                  "Test plan (YAML): the training and hold-out ramps every "
                  "case runs (default: drawn per case)");
  cmd->add_option("--seed", args->seed, "Seed of the cases (default 1)");
  cmd->add_option_function<int>(
      "--threads", [args](const int& n) { args->threads = n; },
      "Candidates fitted side by side per rank (default 2, 1 under MPI)");
  cmd->add_flag("--quiet", args->quiet, "No progress line on a terminal");
  cmd->add_option("--out", args->out,
                  "validate.json to write; the cases done are kept in "
                  "OUT.checkpoint/ until it is written");
  cmd->add_option("--timings", args->timings,
                  "CSV of each case's truth and wall time (seconds) to write "
                  "(what a scheduling study needs)");
  cmd->add_flag("--resume", args->resume,
                "Go on from OUT.checkpoint/ of an interrupted run (same "
                "config, plan and options), or start it when there is none");
  cmd->callback([args, run] { *run = [args] { return RunValidate(*args); }; });
}

}  // namespace kcrig
