#include "apps/campaign_command.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "apps/cli_util.h"
#include "apps/console_options.h"
#include "apps/progress.h"
#include "apps/sil_rig_options.h"
#include "base/atomic_files.h"
#include "campaign/campaign.h"
#include "cluster/input_mirror.h"
#include "cluster/rank_folder.h"
#include "cluster/ranks.h"
#include "diagnosis/diagnosis_io.h"
#include "emulator/sil_rig.h"
#include "estimator/estimate_io.h"
#include "hil/campaign_rig.h"
#include "hil/rig_config.h"
#include "records/run_log.h"
#include "report/report.h"
#include "rt_core/model/channels.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

struct CampaignArgs {
  std::string config_dir;
  std::string rig = "sim";
  int iterations = 3;
  std::string criterion = "D";
  std::string optimizer = "kriging";
  int budget = 100;
  double target_percent = 0;
  SilRigArgs sil;
  ConsoleArgs console;
  bool quiet = false;
  bool no_report = false;
  bool no_diagnose = false;
  bool isolability = false;
  std::string out = "out/campaign";
};

// The model does not explain the logs and the diagnosis names no effect.
constexpr int kExitUnexplained = 5;

std::string FinalTable(const std::vector<CampaignIteration>& iterations) {
  std::string out =
      "campaign summary (estimates in N/mm, +- 95 % half-width):\n";
  char cell[64];
  std::snprintf(cell, sizeof(cell), "  %4s %8s %7s", "iter", "phi[deg]",
                "z_a[m]");
  out += cell;
  // The stiffnesses (the nominal model's parameters); an adopted effect's
  // parameters follow them in an estimate.
  const CampaignIteration& first = iterations.front();
  const std::vector<ParameterEstimate>& stiffnesses =
      first.model == "nominal" ? first.estimate.parameters
                               : first.nominal_estimate.parameters;
  const size_t columns = stiffnesses.size();
  for (const ParameterEstimate& p : stiffnesses) {
    std::snprintf(cell, sizeof(cell), " %18s", p.name.c_str());
    out += cell;
  }
  out += "  model: check\n";
  for (const CampaignIteration& it : iterations) {
    std::snprintf(cell, sizeof(cell), "  %4d %8.2f %7.3f", it.index,
                  it.experiment.phi / kDegree, it.experiment.z_a);
    out += cell;
    for (size_t i = 0; i < columns; ++i) {
      const ParameterEstimate& p = it.estimate.parameters[i];
      const double scale = DisplayScale(p);
      if (p.identifiable) {
        std::snprintf(cell, sizeof(cell), " %9.2f +-%6.2f", p.value * scale,
                      0.5 * (p.ci95_high - p.ci95_low) * scale);
      } else {
        std::snprintf(cell, sizeof(cell), " %9.2f +-   n/a", p.value * scale);
      }
      out += cell;
    }
    out += "  " + it.model + ": " + it.failed_checks +
           (it.action.empty() ? "" : " -> " + it.action) + "\n";
  }
  const CampaignIteration& last = iterations.back();
  for (size_t i = columns; i < last.estimate.parameters.size(); ++i) {
    const ParameterEstimate& p = last.estimate.parameters[i];
    std::snprintf(cell, sizeof(cell), "%.4g +- %.2g %s", p.value,
                  0.5 * (p.ci95_high - p.ci95_low), p.unit.c_str());
    out += "  adopted effect: " + p.name + " " + cell + "\n";
  }
  if (last.action == "stopped") {
    out +=
        "  the campaign stopped: the model does not explain the logs and "
        "no effect of the library does (" +
        (last.rejected_adoption.empty()
             ? std::string("the diagnosis left the gap unexplained")
             : "the attributed effect's model fails too: " +
                   last.rejected_adoption) +
        "; the localisation follows); the estimates are not to be "
        "trusted\n";
  } else if (CampaignCheck(last) != "ok") {
    out +=
        "  the final estimates are NOT to be trusted: the model does not "
        "explain the logs (" +
        CampaignCheck(last) + "); the intervals assume a correct model\n" +
        InadequacyWarning(last.logs);
  }
  return out;
}

// The embedded SIL rig with the user's plant changes; `monitor` (optional)
// watches its runs.
Status EmbeddedRig(const CampaignArgs& args, const KcrigConfig& config,
                   RunMonitor* monitor, RigRunner* rig, std::string* rig_text) {
  PlantConfig plant;
  std::vector<InjectedFault> no_faults;
  KCRIG_RETURN_IF_ERROR(LoadSilPlant(args.sil, config, &plant, &no_faults));
  // One rig for the whole campaign: its plant's state carries over from run
  // to run, as a rig's does.
  auto sil = std::make_shared<SilRig>(config, plant);
  KCRIG_RETURN_IF_ERROR(sil->Start());
  sil->clock()->set_pace(SilRigPace(args.sil, monitor != nullptr));
  RigConnector connect = [sil](const std::string&,
                               std::unique_ptr<RigInterface>* link) {
    *link = sil->Connect({});
    return Status::Ok();
  };
  CampaignRig campaign_rig;
  KCRIG_RETURN_IF_ERROR(CampaignRig::Open("the embedded SIL rig", connect,
                                          sil->clock(), sil->Truth(), config,
                                          &campaign_rig));
  const std::atomic<int>* stop = &InstallStopSignalHandlers();
  *rig = [campaign_rig, stop, monitor](const RampExcitation<double>& excitation,
                                       int run, const std::string& csv_path) {
    return campaign_rig.Run(excitation, run, csv_path, stop, monitor);
  };
  *rig_text =
      DescribeSilRig(args.sil, plant) + DescribePace(sil->clock()->pace());
  return Status::Ok();
}

// The rig of --rig: the embedded one, or a rig over Modbus or CAN (never
// under MPI: the rig loop runs in one process).
Status MakeRig(const CampaignArgs& args, const KcrigConfig& config,
               RunMonitor* monitor, RigRunner* rig, std::string* rig_text) {
  if (args.rig == "sim") {
    return EmbeddedRig(args, config, monitor, rig, rig_text);
  }
  if (args.rig.rfind("modbus-", 0) != 0 && args.rig.rfind("can:", 0) != 0) {
    return Status::Error("--rig " + args.rig +
                         ": expected sim, modbus-tcp://HOST:PORT, "
                         "modbus-rtu://DEVICE or can:IFACE");
  }
  KCRIG_RETURN_IF_ERROR(CheckSilRigOptions(args.sil, args.rig));
  if (WorldRanks().size() > 1) {
    return Status::Error("--rig " + args.rig +
                         ": a rig's loop runs in one process, never under "
                         "MPI (only --rig sim spreads over ranks): start the "
                         "campaign without mpirun");
  }
  CampaignRig hil;
  KCRIG_RETURN_IF_ERROR(CampaignRig::Open(args.rig, config, &hil));
  const std::atomic<int>* stop = &InstallStopSignalHandlers();
  *rig = [hil, stop, monitor](const RampExcitation<double>& excitation, int run,
                              const std::string& csv_path) {
    return hil.Run(excitation, run, csv_path, stop, monitor);
  };
  *rig_text = "rig at " + args.rig;
  return Status::Ok();
}

// Under MPI rank 0 alone runs the rig; every rank receives the log (run.csv
// and its sidecar, bit for bit) and so goes on with the same campaign.
RigRunner RigOfRankZero(RigRunner rig) {
  return [rig](const RampExcitation<double>& excitation, int run,
               const std::string& csv_path) {
    const Ranks& ranks = WorldRanks();
    Status status = Status::Ok();
    if (ranks.is_root()) status = rig(excitation, run, csv_path);
    return ShareFilesInPlace(ranks, status, {csv_path, SidecarPath(csv_path)});
  };
}

Status MakeOptions(const CampaignArgs& args, const KcrigConfig& config,
                   CampaignOptions* options) {
  options->iterations = args.iterations;
  KCRIG_RETURN_IF_ERROR(ParseCriterion(args.criterion, &options->criterion));
  options->optimizer = args.optimizer;
  options->objective.budget = args.budget;
  options->target_relative_halfwidth = args.target_percent / 100.0;
  options->close_loop = !args.no_diagnose;
  options->isolability = args.isolability;
  if (WorldRanks().size() > 1) {
    // The designs' batches and the diagnosis' fits spread over the ranks.
    options->objective.batches = &WorldBatches();
    options->diagnosis.batches = &WorldBatches();
  }
  const int threads = ThreadsPerRank(WorldRanks());
  options->objective.num_threads = threads;
  options->diagnosis.num_threads = threads;
  options->estimator.num_threads = threads;
  return ValidateCampaignOptions(config, *options);
}

// Under MPI every rank's campaign must be rank 0's, bit for bit (the ranks
// meet in the same collectives only while they decide alike): an iteration
// whose campaign.json entry differs from rank 0's (arithmetic that differs
// between nodes) ends the job, naming the rank. Alone: nothing. Collective.
void FollowsRankZero(const CampaignIteration& it, Criterion criterion,
                     std::string folder) {
  const Ranks& ranks = WorldRanks();
  if (ranks.size() == 1) return;
  // As the logs' paths spell it ("out/" gives "out/iteration_0").
  while (folder.size() > 1 && folder.back() == '/') folder.pop_back();
  // campaign.json's entry (no timings) names the logs: in the root's
  // folder or this rank's.
  std::string mine = CampaignToJson(criterion, {it});
  for (size_t at = mine.find(folder);
       !folder.empty() && at != std::string::npos; at = mine.find(folder, at)) {
    mine.replace(at, folder.size(), "OUT");
  }
  std::string root = mine;
  if (!ranks.Share(Status::Ok(), &root).ok() || root == mine) return;
  ranks.AbortJob(1, "kcrig campaign: rank " + std::to_string(ranks.rank()) +
                        ": iteration " + std::to_string(it.index) +
                        " differs from rank 0's (the nodes' arithmetic "
                        "differs); run the campaign on one node");
}

// The output folder, made before any rank starts (an error then is every
// rank's, not rank 0's alone mid-campaign).
Status MakeOutputFolder(const std::string& out) {
  std::error_code error;
  std::filesystem::create_directories(out, error);
  if (error) {
    return Status::Error("--out " + out + ": cannot create (" +
                         error.message() + ")");
  }
  return Status::Ok();
}

// The campaign as the user sees it: progress, campaign.json, the report;
// and on the console (`feed`, optional) the stages, iterations and report.
int RunAndReport(const CampaignArgs& args, const KcrigConfig& config,
                 const RigRunner& rig, const std::string& rig_text,
                 CampaignOptions options, LiveFeed* feed) {
  const StopSignal stop_signal;
  const CommandError fail("campaign");
  Status status;
  ProgressLine progress(args.quiet);
  options.callback =
      stop_signal.Callback([&progress, feed](const IterationSummary& s) {
        progress.Show(s.stage);
        if (feed != nullptr) feed->Stage(s.stage);
      });
  // campaign.json lists the complete iterations as each completes, so an
  // end by a signal (mpirun's too) keeps them.
  const std::string summary =
      (std::filesystem::path(args.out) / "campaign.json").string();
  std::vector<CampaignIteration> complete;
  Status written = Status::Ok();
  options.on_iteration = [&](const CampaignIteration& it) {
    progress.Clear();
    std::printf("%s\n",
                CampaignIterationSummary(it, options.criterion).c_str());
    std::fflush(stdout);
    FollowsRankZero(it, options.criterion, args.out);
    if (feed != nullptr) {
      feed->Iteration(CampaignIterationToJson(it));
    }
    complete.push_back(it);
    if (written.ok()) {
      written = WriteFilesAtomically(
          {{summary, CampaignToJson(options.criterion, complete)}});
    }
  };
  std::printf(
      "kcrig campaign: %s, criterion %s, optimizer %s, up to %d designed "
      "experiments; output in %s\n\n",
      rig_text.c_str(), CriterionName(options.criterion),
      args.optimizer.c_str(), args.iterations, args.out.c_str());
  std::vector<CampaignIteration> iterations;
  status = RunCampaign(config, options, rig, args.out, &iterations);
  progress.Clear();
  if (!iterations.empty()) {
    if (!written.ok()) return fail(written);
    std::printf(
        "%s  wrote %s (and iteration_*/run.csv, est.json, design.json)\n",
        FinalTable(iterations).c_str(), summary.c_str());
    std::fflush(stdout);
  }
  // Every file written is complete; campaign.json lists the complete
  // iterations.
  if (stop_signal.received()) {
    return stop_signal.Exit(
        "campaign", iterations.empty()
                        ? "no iteration complete"
                        : "kept the " + std::to_string(iterations.size()) +
                              " complete iteration(s)");
  }
  if (!status.ok()) return fail(status);
  const bool stopped =
      !iterations.empty() && iterations.back().action == "stopped";
  if (stopped) {
    std::printf("%s\n", DiagnosisSummary(iterations.back().diagnosis).c_str());
  }
  if (!args.no_report) {
    const std::string html =
        (std::filesystem::path(args.out) / "report.html").string();
    ReportOptions report_options;
    ConfiguredDbc(config, &report_options.dbc_file);
    report_options.callback =
        stop_signal.Callback([&progress](const IterationSummary& s) {
          progress.Show("report: " + s.stage, s.fraction);
        });
    ReportSummary report;
    status = WriteReport(config, args.out, html, report_options, &report);
    progress.Clear();
    if (!status.ok() && stop_signal.received()) {
      return stop_signal.Exit("campaign",
                              "kept all iterations, no report written");
    }
    // The campaign's own outputs are complete: a report that cannot be
    // written is a warning (kcrig report can retry), not a failed campaign.
    if (status.ok()) {
      if (feed != nullptr) {
        feed->ReportWritten(std::filesystem::absolute(html).string());
      }
      std::printf("  report with %d figures: %s (open it in a browser)\n",
                  report.figures, html.c_str());
      std::printf("  %s\n", KcSheetLine(report).c_str());
    } else {
      std::fprintf(stderr, "kcrig campaign: warning: no report: %s\n",
                   status.message().c_str());
    }
  }
  return stopped ? kExitUnexplained : 0;
}

// rig.yaml's realtime.cpu for a rig's loop (-1: the embedded rig's virtual
// clock pins nothing; a rig.yaml that does not load is reported when the
// rig opens).
int LoopCpu(const CampaignArgs& args, const KcrigConfig& config) {
  RigConfig rig;
  if (args.rig == "sim" || !LoadRigConfig(config.directory, &rig).ok()) {
    return -1;
  }
  return rig.realtime.cpu;
}

// The console's last line: how the campaign ended.
std::string CampaignOutcome(int code) {
  if (code == 0) return "the campaign completed";
  if (code == kExitUnexplained) {
    return "the campaign stopped: the model does not explain the logs";
  }
  if (code > 128) return "the campaign was stopped (operator stop or signal)";
  return "the campaign failed (the terminal says why)";
}

int RunCampaignCommand(const CampaignArgs& args) {
  // Rank 0 alone reads the inputs; the other ranks their copies.
  const Ranks& ranks = WorldRanks();
  InputMirror mirror(ranks);
  std::string config_dir = args.config_dir;
  Status status = MirrorConfig(&mirror, &config_dir);
  KcrigConfig config;
  RigRunner rig;
  std::string rig_text;
  CampaignOptions options;
  std::unique_ptr<LiveConsole> console;  // rank 0's: it runs the rig
  if (status.ok()) status = LoadConfig(config_dir, &config);
  if (status.ok() && ranks.is_root()) {
    status = StartConsole(args.console, "kcrig campaign", LoopCpu(args, config),
                          &console);
  }
  LiveFeed* feed = console != nullptr ? &console->feed() : nullptr;
  if (status.ok()) status = MakeRig(args, config, feed, &rig, &rig_text);
  if (status.ok()) status = MakeOptions(args, config, &options);
  if (status.ok() && ranks.is_root()) status = MakeOutputFolder(args.out);
  status = ranks.Agree(status);
  if (!status.ok()) {
    if (console != nullptr) console->Shutdown(status.message());
    return CommandError("campaign")(status);
  }
  if (feed != nullptr) feed->Title("kcrig campaign");
  if (ranks.size() == 1) {
    const int code = RunAndReport(args, config, rig, rig_text, options, feed);
    if (console != nullptr) console->Shutdown(CampaignOutcome(code));
    return code;
  }
  if (ranks.is_root()) {
    const int code =
        RunAndReport(args, config, RigOfRankZero(rig), rig_text, options, feed);
    if (console != nullptr) console->Shutdown(CampaignOutcome(code));
    // An error rank 0 met alone (its output folder) leaves the others in a
    // collective: the job ends with it.
    if (code != 0 && code != kExitUnexplained) {
      ranks.AbortJob(code, "");  // rank 0 has said why
    }
    return code;
  }
  // The other ranks follow rank 0's rig, in a folder of their own.
  const RankFolder folder("campaign", ranks.rank());
  options.on_iteration = [&](const CampaignIteration& it) {
    FollowsRankZero(it, options.criterion, folder.path());
  };
  std::vector<CampaignIteration> followed;
  status = folder.status();
  if (status.ok()) {
    status = RunCampaign(config, options, RigOfRankZero(rig), folder.path(),
                         &followed);
  }
  // Rank 0's own error (the rig's, shared) is rank 0's to report.
  if (status.ok() || status.message().rfind("rank 0: ", 0) == 0) {
    return status.ok() ? 0 : 1;
  }
  // This rank's alone, while rank 0 may wait in a collective: the job ends
  // (after rank 0 has had time to report an error of its own first).
  std::this_thread::sleep_for(std::chrono::seconds(5));
  folder.Remove();
  mirror.Remove();
  ranks.AbortJob(1, "kcrig campaign: rank " + std::to_string(ranks.rank()) +
                        ": " + status.message());
}

}  // namespace

void AddCampaignCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<CampaignArgs>();
  CLI::App* cmd = app->add_subcommand(
      "campaign",
      "The two-level loop: estimate -> design the next excitation -> run it "
      "on the rig -> estimate again");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--rig", args->rig,
                  "sim (the embedded SIL rig), modbus-tcp://HOST:PORT, "
                  "modbus-rtu://DEVICE (a rig or kcrig emulate) or can:IFACE")
      ->capture_default_str();
  cmd->add_option("--iterations", args->iterations,
                  "Designed experiments after the initial one")
      ->capture_default_str();
  cmd->add_option("--criterion", args->criterion, "D, A, E or MM")
      ->capture_default_str();
  cmd->add_option("--optimizer", args->optimizer,
                  "imfil, kriging, nlopt:NAME or grid (see kcrig design)")
      ->capture_default_str();
  cmd->add_option("--budget", args->budget,
                  "Most criterion evaluations per design")
      ->capture_default_str();
  cmd->add_option("--target-halfwidth", args->target_percent,
                  "Stop when every 95 % half-width is within this percentage "
                  "of its estimate (0: run all iterations)")
      ->capture_default_str();
  AddSilRigOptions(cmd, &args->sil, /*with_faults=*/false);
  AddConsoleOptions(cmd, &args->console);
  cmd->add_flag("--quiet", args->quiet, "No progress line");
  cmd->add_flag("--no-diagnose", args->no_diagnose,
                "Check the model every iteration but do not diagnose or act "
                "on a failed check (it is reported; the campaign goes on "
                "with the nominal model)");
  cmd->add_flag("--isolability", args->isolability,
                "Say each iteration which faults the logs tell apart and "
                "how many ties the next experiment leaves (kcrig "
                "isolability; about 0.6 s an iteration)");
  cmd->add_flag("--no-report", args->no_report,
                "Do not write OUT/report.html at the end");
  cmd->add_option("--out", args->out, "Output folder")->capture_default_str();
  cmd->callback(
      [args, run] { *run = [args] { return RunCampaignCommand(*args); }; });
}

}  // namespace kcrig
