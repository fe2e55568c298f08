#include "apps/export_command.h"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "apps/cli_util.h"
#include "records/mat_run_log.h"
#include "records/read_log.h"
#include "records/run_log.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

struct ExportArgs {
  std::string config_dir;
  std::string log;
  std::string out;
};

int RunExport(const ExportArgs& args) {
  auto fail = [](const Status& status) {
    std::fprintf(stderr, "kcrig export: %s\n", status.message().c_str());
    return 1;
  };
  const std::string extension =
      std::filesystem::path(args.out).extension().string();
  if (extension != ".mat" && extension != ".csv") {
    return fail(
        Status::Error("--out " + args.out +
                      ": the format goes by the extension, .mat "
                      "(MATLAB MAT-file) or .csv (run.csv + run.json)"));
  }
  Status status = CheckOutput("--out", args.out, {args.log});
  if (status.ok() && extension == ".csv") {
    status = CheckOutput("--out", SidecarPath(args.out), {args.log});
  }
  if (!status.ok()) return fail(status);
  CanLogDecoderOptions can;
  if (IsCanBusLog(args.log)) {
    KcrigConfig config;
    status = LoadConfig(args.config_dir, &config);
    if (status.ok()) status = ConfiguredDbc(config, &can.dbc_file);
    if (!status.ok()) return fail(status);
    can.sigma_position = config.experiment.sigma_position;
    can.sigma_angle = config.experiment.sigma_angle;
  }
  RunLog log;
  status = ReadLog(args.log, can, &log);
  if (!status.ok()) return fail(status);
  status = extension == ".mat" ? WriteMatRunLog(args.out, log)
                               : WriteRunLog(args.out, log);
  if (!status.ok()) return fail(status);
  std::printf("kcrig export: %zu samples of %s, wrote %s\n", log.samples.size(),
              args.log.c_str(), args.out.c_str());
  return 0;
}

}  // namespace

void AddExportCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* cmd = app->add_subcommand(
      "export",
      "Write a run log as a MATLAB MAT-file (.mat) or as run.csv + run.json");
  cmd->add_option("--config", args->config_dir,
                  "Config directory, for a CAN bus log's DBC and sigmas");
  cmd->add_option("--log", args->log,
                  "Run log: run.csv, a MAT-file or a CAN bus log")
      ->required();
  cmd->add_option("--out", args->out, "File to write: .mat or .csv")
      ->required();
  cmd->callback([args, run] { *run = [args] { return RunExport(*args); }; });
}

}  // namespace kcrig
