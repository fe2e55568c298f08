// kcrig: thin entry point. Parses the command line, runs one subcommand.
#include <glog/logging.h>

#include <csignal>
#include <cstdio>
#include <exception>
#include <functional>
#include <string>

#include "CLI/CLI.hpp"
#include "apps/campaign_command.h"
#include "apps/can_log_command.h"
#include "apps/cli_util.h"
#include "apps/design_command.h"
#include "apps/diagnose_command.h"
#include "apps/emulate_command.h"
#include "apps/estimate_command.h"
#include "apps/export_command.h"
#include "apps/isolability_command.h"
#include "apps/kc_command.h"
#include "apps/report_command.h"
#include "apps/run_command.h"
#include "apps/screen_command.h"
#include "apps/simulate_command.h"
#include "apps/timing_check_command.h"
#include "apps/validate_command.h"
#include "cluster/ranks.h"

int main(int argc, char** argv) {
  // Over a file-size limit (ulimit -f) a write then fails (EFBIG) and is
  // handled as a full disk, instead of the signal killing the process.
  std::signal(SIGXFSZ, SIG_IGN);
  // The solver's own logging (Ceres, through glog) never reaches the
  // terminal nor a log file: what it would say comes back as kcrig's one
  // line (the solver's summary), never as a residual dump.
  FLAGS_logtostderr = true;
  FLAGS_minloglevel = google::GLOG_FATAL;
  google::InitGoogleLogging(argv[0]);
  // Joins MPI under mpirun (kcrig validate spreads its cases), until exit.
  kcrig::Ranks ranks(&argc, &argv);
  CLI::App app{
      "kcrig: real-time HIL controller and offline tools for a hydraulic "
      "kinematics-and-compliance suspension rig"};
  app.require_subcommand(1);
  std::function<int()> run;
  kcrig::AddSimulateCommand(&app, &run);
  kcrig::AddEstimateCommand(&app, &run);
  kcrig::AddScreenCommand(&app, &run);
  kcrig::AddDiagnoseCommand(&app, &run);
  kcrig::AddIsolabilityCommand(&app, &run);
  kcrig::AddKcCommand(&app, &run);
  kcrig::AddDesignCommand(&app, &run);
  kcrig::AddCampaignCommand(&app, &run);
  kcrig::AddEmulateCommand(&app, &run);
  kcrig::AddRunCommand(&app, &run);
  kcrig::AddTimingCheckCommand(&app, &run);
  kcrig::AddCanLogCommand(&app, &run);
  kcrig::AddExportCommand(&app, &run);
  kcrig::AddReportCommand(&app, &run);
  kcrig::AddValidateCommand(&app, &run);
  kcrig::RequireDecimalNumbers(&app);
  // CLI11 would call an unknown subcommand an "extra argument"; say it plainly.
  const auto is_subcommand = [&app](const std::string& name) {
    for (const CLI::App* sub : app.get_subcommands({})) {
      if (sub->get_name() == name) return true;
    }
    return false;
  };
  if (argc > 1 && argv[1][0] != '-' && !is_subcommand(argv[1])) {
    std::fprintf(stderr,
                 "kcrig: error: unknown subcommand '%s' (see kcrig --help)\n",
                 kcrig::EscapeControl(argv[1]).c_str());
    return 2;
  }
  // Under mpirun only the batch commands spread (every rank runs the
  // command, the batches are shared out); rank 0 alone prints and writes.
  if (!ranks.launch_error().empty()) {
    std::fprintf(stderr, "kcrig: %s\n", ranks.launch_error().c_str());
    return 1;
  }
  if (ranks.size() > 1 && argc > 1 && argv[1][0] != '-') {
    const std::string command = argv[1];
    if (command != "validate" && command != "design" && command != "diagnose" &&
        command != "campaign") {
      if (ranks.is_root()) {
        std::fprintf(
            stderr,
            "kcrig %s: runs in one process (only validate, design, "
            "diagnose and campaign --rig sim spread over MPI ranks): start "
            "it without mpirun\n",
            command.c_str());
      }
      return 1;
    }
    if (!ranks.is_root()) ranks.SilenceOutput();
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // One line, whatever CLI11 would have printed.
    std::fprintf(stderr, "kcrig: error: %s (see kcrig --help)\n",
                 kcrig::EscapeControl(e.what()).c_str());
    return 2;
  }
  // The commands return their errors; an exception that still escapes (a
  // library's, on input nobody foresaw) is one line and exit 1, never an
  // abort. Outputs are written atomically at the end: nothing half-written.
  // Under several ranks the others may wait in a collective: the job ends.
  std::string why;
  try {
    return run();
  } catch (const std::exception& e) {
    why = e.what();
  } catch (...) {
    why = "an unexpected failure";
  }
  const std::string rank =
      ranks.size() > 1 ? "rank " + std::to_string(ranks.rank()) + ": " : "";
  const std::string line = "kcrig " + kcrig::EscapeControl(argv[1]) + ": " +
                           rank + "error: " + kcrig::EscapeControl(why);
  if (ranks.size() > 1) ranks.AbortJob(1, line);
  std::fprintf(stderr, "%s\n", line.c_str());
  return 1;
}
