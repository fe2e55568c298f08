#include "apps/report_command.h"

#include <charconv>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "apps/cli_util.h"
#include "apps/progress.h"
#include "report/report.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

struct ReportArgs {
  std::string config_dir;
  std::string from;
  std::string out;
  std::string grid = "19x11";
  bool quiet = false;
};

int RunReport(const ReportArgs& args) {
  const StopSignal stop;
  const CommandError fail("report");
  KcrigConfig config;
  Status status = LoadConfig(args.config_dir, &config);
  if (!status.ok()) return fail(status);
  const std::string out =
      args.out.empty()
          ? (std::filesystem::path(args.from) / "report.html").string()
          : args.out;
  status = CheckOutput(
      "--out", out,
      {(std::filesystem::path(args.from) / "campaign.json").string()});
  if (!status.ok()) return fail(status);
  ReportOptions options;
  // Without a readable rig.yaml a CAN log's overlay is left out with a note.
  ConfiguredDbc(config, &options.dbc_file);
  const char* begin = args.grid.data();
  const char* end = begin + args.grid.size();
  const auto phi = std::from_chars(begin, end, options.surface_phi_points);
  const bool has_x = phi.ec == std::errc() && phi.ptr != end && *phi.ptr == 'x';
  const auto z =
      has_x ? std::from_chars(phi.ptr + 1, end, options.surface_z_points)
            : std::from_chars_result{end, std::errc::invalid_argument};
  if (!has_x || z.ec != std::errc() || z.ptr != end ||
      options.surface_phi_points < 2 || options.surface_z_points < 2 ||
      options.surface_phi_points > 200 || options.surface_z_points > 200) {
    return fail(Status::Error("--grid " + args.grid +
                              ": expected PHIxZ, 2..200 points each (e.g. "
                              "19x11)"));
  }
  ReportSummary summary;
  {
    ProgressLine line(args.quiet);
    options.callback = stop.Callback([&line](const IterationSummary& s) {
      line.Show("kcrig report: " + s.stage, s.fraction);
    });
    status = WriteReport(config, args.from, out, options, &summary);
    line.Clear();
  }
  // A report finished before the signal is complete and stays.
  if (!status.ok() && stop.received()) return stop.Exit("report");
  if (!status.ok()) return fail(status);
  std::printf("kcrig report: %d figures (%d experiments%s%s%s%s), wrote %s\n",
              summary.figures, summary.experiments,
              summary.campaign ? ", campaign" : "",
              summary.diagnosis ? ", diagnosis" : "",
              summary.timing ? ", timing" : "",
              summary.validation ? ", validation" : "", out.c_str());
  if (summary.campaign) std::printf("  %s\n", KcSheetLine(summary).c_str());
  return 0;
}

}  // namespace

void AddReportCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<ReportArgs>();
  CLI::App* cmd = app->add_subcommand(
      "report",
      "Self-contained HTML report with plots of a campaign folder (and any "
      "diag.json, timing.json in it)");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--from", args->from, "Campaign output folder")->required();
  cmd->add_option("--out", args->out,
                  "report.html to write (default: FROM/report.html)");
  cmd->add_option("--grid", args->grid,
                  "Criterion surface grid, points along phi x z_a")
      ->capture_default_str();
  cmd->add_flag("--quiet", args->quiet, "No progress line");
  cmd->callback([args, run] { *run = [args] { return RunReport(*args); }; });
}

}  // namespace kcrig
