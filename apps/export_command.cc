#include "apps/export_command.h"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "apps/cli_util.h"
#include "records/mat_run_log.h"
#include "records/read_log.h"
#include "records/run_log.h"

namespace kcrig {
namespace {

struct ExportArgs {
  std::string log;
  std::string out;
};

int RunExport(const ExportArgs& args) {
  const CommandError fail("export");
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
  if (IsCanBusLog(args.log)) {
    return fail(Status::Error(
        args.log +
        ": a CAN bus log carries no record of its excitation; export the "
        "run.csv the run wrote beside it"));
  }
  RunLog log;
  status = ReadLog(args.log, CanLogDecoderOptions(), &log);
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
  cmd->add_option("--log", args->log, "Run log: run.csv or a MAT-file")
      ->required();
  cmd->add_option("--out", args->out, "File to write: .mat or .csv")
      ->required();
  cmd->callback([args, run] { *run = [args] { return RunExport(*args); }; });
}

}  // namespace kcrig
