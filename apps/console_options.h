// --console and --console-remote of `kcrig run` and `kcrig campaign`: the
// live operator page (console/live_console.h), started before the run,
// its URL (with the token) printed on the terminal, its stop button wired
// to the same ramp-down as Ctrl-C.
#ifndef KCRIG_APPS_CONSOLE_OPTIONS_H_
#define KCRIG_APPS_CONSOLE_OPTIONS_H_

#include <memory>
#include <string>

#include "CLI/CLI.hpp"
#include "base/status.h"
#include "console/live_console.h"

namespace kcrig {

struct ConsoleArgs {
  std::string address;  // "" = no console
  bool remote = false;
};

void AddConsoleOptions(CLI::App* cmd, ConsoleArgs* args);

// Starts the console of `command` ("kcrig run") when --console was given
// (else leaves *console null) and prints its URL; a warning when it is
// reachable beyond this machine. `loop_cpu`: rig.yaml's realtime.cpu
// (-1: not pinned), which the console's threads keep off. One-line errors.
Status StartConsole(const ConsoleArgs& args, const std::string& command,
                    int loop_cpu, std::unique_ptr<LiveConsole>* console);

}  // namespace kcrig

#endif  // KCRIG_APPS_CONSOLE_OPTIONS_H_
