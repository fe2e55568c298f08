#include "apps/console_options.h"

#include <cstdio>
#include <utility>

#include "apps/progress.h"
#include "report/report.h"

namespace kcrig {

void AddConsoleOptions(CLI::App* cmd, ConsoleArgs* args) {
  cmd->add_option("--console", args->address,
                  "Serve a live operator page at HOST:PORT (or PORT, on "
                  "loopback; 0 picks a free port): charts, safety margins, "
                  "timing, a campaign's iterations and a stop button. The "
                  "URL printed carries the page's token");
  cmd->add_flag("--console-remote", args->remote,
                "Allow --console on an address that is not loopback "
                "(anyone on that network who has the URL can watch and stop "
                "the run)");
}

Status StartConsole(const ConsoleArgs& args, const std::string& command,
                    int loop_cpu, std::unique_ptr<LiveConsole>* console) {
  console->reset();
  if (args.address.empty()) {
    if (args.remote) return Status::Error("--console-remote needs --console");
    return Status::Ok();
  }
  ConsoleOptions options;
  options.address = args.address;
  options.allow_remote = args.remote;
  options.loop_cpu = loop_cpu;
  options.plotly_js = ReportOptions().plotly_js;
  // The first signal's path: the loop ramps down, a campaign stops.
  options.on_stop = [] { RequestOperatorStop(); };
  options.on_failure = [command](const std::string& line) {
    std::fprintf(stderr, "%s: warning: %s\n", command.c_str(), line.c_str());
  };
  KCRIG_RETURN_IF_ERROR(LiveConsole::Start(std::move(options), console));
  std::printf("%s: console at %s\n", command.c_str(),
              (*console)->url().c_str());
  if ((*console)->remote()) {
    std::fprintf(stderr,
                 "%s: warning: the console listens beyond this machine: "
                 "anyone on that network with the URL can watch and stop "
                 "the run\n",
                 command.c_str());
  }
  std::fflush(stdout);
  return Status::Ok();
}

}  // namespace kcrig
