#include "apps/kc_command.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "apps/cli_util.h"
#include "base/atomic_files.h"
#include "estimator/estimate_io.h"
#include "estimator/experiment.h"
#include "kc_sheet/kc_sheet.h"
#include "kc_sheet/kc_sheet_io.h"
#include "records/read_log.h"
#include "records/run_log.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

struct KcArgs {
  std::string config_dir;
  std::vector<std::string> logs;
  std::string estimate;
  std::string convention = "iso";
  std::optional<double> contact_patch_z;
  std::string out;
  std::string csv;
};

// The model at the estimate of `path` (the config's without one): its
// values over the config's, an adopted effect's too, and its covariance
// for the model's standard errors.
Status ModelAtEstimate(const std::string& path, const KcrigConfig& config,
                       KcModel* model) {
  EstimateFile estimate;
  if (!path.empty()) KCRIG_RETURN_IF_ERROR(ReadEstimateFile(path, &estimate));
  const Status status = KcModelOfEstimate(
      config.model, estimate.names, estimate.values, estimate.covariance,
      estimate.integrator_step > 0 ? estimate.integrator_step
                                   : config.experiment.step,
      model);
  if (!status.ok()) return Status::Error(path + ": " + status.message());
  return Status::Ok();
}

int RunKc(const KcArgs& args) {
  const CommandError fail("kc");
  KcrigConfig config;
  Status status = LoadConfig(args.config_dir, &config);
  if (!status.ok()) return fail(status);
  std::vector<std::string> inputs = args.logs;
  if (!args.estimate.empty()) inputs.push_back(args.estimate);
  for (const auto& [option, file] :
       {std::pair{"--out", args.out}, std::pair{"--csv", args.csv}}) {
    status = CheckOutput(option, file, inputs);
    if (!status.ok()) return fail(status);
  }
  if (!args.out.empty() && args.out == args.csv) {
    return fail(Status::Error("--csv: the same file as --out"));
  }
  KcSheetOptions options;
  if (args.convention == "sae") {
    options.convention = SignConvention::kSae;
  } else if (args.convention != "iso") {
    return fail(Status::Error("--convention: \"" + args.convention +
                              "\" is neither iso nor sae"));
  }
  if (args.contact_patch_z) {
    if (!(*args.contact_patch_z < 0 && *args.contact_patch_z > -2)) {
      return fail(Status::Error(
          "--contact-patch-z: must be within (-2, 0) m (below the wheel "
          "centre)"));
    }
    options.contact_patch_z = *args.contact_patch_z;
  }
  std::string dbc_file;
  if (std::any_of(args.logs.begin(), args.logs.end(), IsCanBusLog)) {
    status = ConfiguredDbc(config, &dbc_file);
    if (!status.ok()) return fail(status);
  }
  std::vector<RunLog> logs(args.logs.size());
  std::vector<Experiment> experiments(args.logs.size());
  std::vector<KcRun> runs;
  for (size_t i = 0; i < args.logs.size(); ++i) {
    status = LoadExperiment(args.logs[i], config, dbc_file, &experiments[i],
                            &logs[i]);
    if (!status.ok()) return fail(status);
    runs.push_back({&logs[i], &experiments[i]});
  }
  KcModel model;
  status = ModelAtEstimate(args.estimate, config, &model);
  if (!status.ok()) return fail(status);
  KcSheet sheet;
  status = ComputeKcSheet(runs, &model, options, &sheet);
  if (!status.ok()) return fail(status);
  std::vector<std::pair<std::string, std::string>> files;
  if (!args.out.empty()) files.push_back({args.out, KcSheetToJson(sheet)});
  if (!args.csv.empty()) files.push_back({args.csv, KcSheetToCsv(sheet)});
  status = WriteFilesAtomically(files);
  if (!status.ok()) return fail(status);
  std::fputs(KcSheetSummary(sheet).c_str(), stdout);
  for (const auto& [path, content] : files) {
    std::printf("  wrote %s\n", path.c_str());
  }
  return 0;
}

}  // namespace

void AddKcCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<KcArgs>();
  CLI::App* cmd = app->add_subcommand(
      "kc",
      "K&C sheet of run logs: compliance gradients, hysteresis, model vs rig");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--log", args->logs,
                  "Run log run.csv or CAN bus log (repeatable; runs in two "
                  "directions at one height give gradients per force "
                  "component)")
      ->required();
  cmd->add_option("--estimate", args->estimate,
                  "est.json: the model at this estimate, with its "
                  "uncertainty (default: the config's values)");
  cmd->add_option("--convention", args->convention,
                  "Axes of the sheet: iso (ISO 8855, the logs' frame) or sae "
                  "(SAE J670)");
  cmd->add_option("--contact-patch-z", args->contact_patch_z,
                  "Height of the contact patch below the wheel centre [m, < "
                  "0]: also the model's compliance at the contact patch");
  cmd->add_option("--out", args->out, "kc.json to write");
  cmd->add_option("--csv", args->csv, "Gradients CSV to write");
  cmd->callback([args, run] { *run = [args] { return RunKc(*args); }; });
}

}  // namespace kcrig
