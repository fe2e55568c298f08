#include "apps/diagnose_command.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "apps/cli_util.h"
#include "apps/progress.h"
#include "base/atomic_files.h"
#include "cluster/ranks.h"
#include "designer/discrimination.h"
#include "diagnosis/diagnosis.h"
#include "diagnosis/diagnosis_io.h"
#include "records/run_log.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

struct DiagnoseArgs {
  std::string config_dir;
  std::vector<std::string> logs;
  std::vector<std::string> holdout;
  std::string candidates;
  bool no_pairs = false;
  std::optional<int> free_parameters;
  std::optional<int> threads;
  bool quiet = false;
  std::string out;
};

// What every rank reads and checks alike before the diagnosis.
struct DiagnoseInputs {
  KcrigConfig config;
  DiagnosisOptions options;
  std::vector<Experiment> training, holdout;
};

// A hold-out log is evidence only if the fit never saw it: refused when it
// holds the same samples as a training log (the same file, a copy, or the
// same run in another format).
Status CheckHoldoutUnseen(const std::vector<Experiment>& training,
                          const std::vector<Experiment>& holdout) {
  for (const Experiment& h : holdout) {
    for (const Experiment& t : training) {
      if (h.measured == t.measured && h.forces == t.forces) {
        return Status::Error("--holdout " + h.source +
                             ": holds the same samples as the training log " +
                             t.source +
                             " (a hold-out must be a run the fit never saw)");
      }
    }
  }
  return Status::Ok();
}

Status Prepare(const DiagnoseArgs& args, DiagnoseInputs* in) {
  Status status = LoadConfig(args.config_dir, &in->config);
  if (!status.ok()) return status;
  std::vector<std::string> inputs = args.logs;
  inputs.insert(inputs.end(), args.holdout.begin(), args.holdout.end());
  status = CheckOutput("--out", args.out, inputs);
  if (!status.ok()) return status;
  if (!args.candidates.empty()) {
    in->options.candidates = SplitList(args.candidates);
    for (const std::string& name : in->options.candidates) {
      std::vector<std::string> effects;
      std::vector<BushingSet> places;
      const Status placed = ParseModelName(name, &effects, &places);
      if (!placed.ok() || effects.size() != 1) {
        return Status::Error(
            "--candidates: '" + name + "': " +
            (placed.ok() ? "one effect per candidate" : placed.message()));
      }
      if (std::find(kEffectNames.begin(), kEffectNames.end(), effects[0]) ==
              kEffectNames.end() &&
          effects[0] != kModelParameter) {
        return Status::Error("--candidates: unknown effect '" + effects[0] +
                             "' (one of bushing_damping, hysteresis, "
                             "progressive_stiffness, actuator_lag, "
                             "rig_compliance, sensor_offset, "
                             "model_parameter@NAME)");
      }
    }
  }
  in->options.consider_pairs = !args.no_pairs;
  // Candidates given by hand are all that is fitted unless asked otherwise.
  in->options.model_parameter_pool = args.free_parameters.value_or(
      args.candidates.empty() ? in->options.model_parameter_pool : 0);
  if (args.threads && *args.threads < 1) {
    return Status::Error("--threads: must be >= 1");
  }
  // Under mpirun the candidate fits spread over the ranks.
  in->options.batches = &WorldBatches();
  in->options.num_threads = ThreadsPerRank(WorldRanks(), args.threads);

  status = LoadLogs(args.logs, in->config, &in->training);
  if (!status.ok()) return status;
  status = LoadLogs(args.holdout, in->config, &in->holdout);
  if (!status.ok()) return status;
  return CheckHoldoutUnseen(in->training, in->holdout);
}

int RunDiagnose(const DiagnoseArgs& args) {
  const StopSignal stop;
  const CommandError fail("diagnose");
  // Rank 0 alone reads the inputs; the other ranks their copies.
  InputMirror mirror(WorldRanks());
  DiagnoseArgs read = args;
  Status status = MirrorConfig(&mirror, &read.config_dir);
  if (status.ok()) status = MirrorLogs(&mirror, &read.logs);
  if (status.ok()) status = MirrorLogs(&mirror, &read.holdout);
  DiagnoseInputs in;
  if (status.ok()) status = Prepare(read, &in);
  status = WorldRanks().Agree(status);
  if (!status.ok()) return fail(status);
  const KcrigConfig& config = in.config;
  DiagnosisOptions& options = in.options;

  DiagnosisResult result;
  {
    ProgressLine line(args.quiet);
    options.callback = stop.Callback([&line](const IterationSummary& s) {
      line.Show("kcrig diagnose: " + s.stage, s.fraction);
    });
    status = Diagnose(config.model, in.training, in.holdout, options,
                      config.experiment.step, &result);
    line.Clear();
  }
  if (stop.received()) return stop.Exit("diagnose");
  if (!status.ok()) return fail(status);
  std::string design_json;
  DiscriminatingDesign design;
  // Two candidates the data cannot tell apart, or a verdict of low
  // confidence and its rival: the experiment that tells them apart.
  std::string model_a = result.ambiguous_a, model_b = result.ambiguous_b;
  if (model_a.empty() && result.confidence == "low" && !result.rival.empty()) {
    model_a = result.model;
    model_b = result.rival;
  }
  if (!model_a.empty()) {
    // The diagnosis stands without it: a failed design is a warning.
    status =
        DesignToTellApart(config, options, result, model_a, model_b, &design);
    if (status.ok()) {
      design_json = DiscriminatingDesignToJson(design);
    } else {
      std::fprintf(stderr,
                   "kcrig diagnose: warning: no discriminating design: %s\n",
                   status.message().c_str());
    }
  }
  if (stop.received()) return stop.Exit("diagnose");
  if (!args.out.empty() && WorldRanks().is_root()) {
    status = WriteFilesAtomically(
        {{args.out,
          DiagnosisToJson(result, args.logs, args.holdout, design_json)}});
    if (!status.ok()) return fail(status);
  }
  std::fputs(DiagnosisSummary(result).c_str(), stdout);
  if (!design_json.empty()) {
    std::printf(
        "  to tell %s from %s, run: --phi %.1f --z %.3f --duration %.2f "
        "--hold %.2f --return %.2f (predictions differ by %.3g noise "
        "variances)\n",
        design.model_a.c_str(), design.model_b.c_str(),
        design.excitation.phi / kDegree, design.excitation.z_a,
        design.excitation.duration, design.excitation.hold,
        design.excitation.return_duration, design.divergence);
  }
  std::printf("  %.1f s", result.seconds);
  if (!args.out.empty()) std::printf(", wrote %s", args.out.c_str());
  std::printf("\n");
  return 0;
}

}  // namespace

void AddDiagnoseCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<DiagnoseArgs>();
  CLI::App* cmd = app->add_subcommand(
      "diagnose",
      "Sim-to-real gap: is there one, where, which unmodelled effect, how "
      "far it shrinks");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--log", args->logs,
                  "Training log, run.csv or can.log (repeatable)")
      ->required();
  cmd->add_option("--holdout", args->holdout,
                  "Held-out log the candidates are scored on, never fitted "
                  "(repeatable; default: cross-validation over the --log "
                  "files)");
  cmd->add_option("--candidates", args->candidates,
                  "Comma-separated candidate effects (default: all six), or "
                  "model_parameter@NAME");
  cmd->add_flag("--no-pairs", args->no_pairs,
                "Do not try pairs of effects when the best single one "
                "leaves structure beyond the noise");
  const int freeable = static_cast<int>(FreeableModelParameters().size());
  cmd->add_option_function<int>(
         "--free-parameters",
         [args](const int& n) { args->free_parameters = n; },
         "Most model parameters the screening frees as candidates "
         "(model_parameter@NAME; default 3, 0 with --candidates; 0: none)")
      ->check(CLI::Range(0, freeable));
  cmd->add_option_function<int>(
      "--threads", [args](const int& n) { args->threads = n; },
      "Candidates fitted side by side per process (default 2; 1 under MPI, "
      "where the fits spread over the ranks)");
  cmd->add_flag("--quiet", args->quiet, "No progress line on a terminal");
  cmd->add_option("--out", args->out, "diag.json to write");
  cmd->callback([args, run] { *run = [args] { return RunDiagnose(*args); }; });
}

}  // namespace kcrig
