// `kcrig simulate`: the model for one excitation, written as a run log.
#ifndef KCRIG_APPS_SIMULATE_COMMAND_H_
#define KCRIG_APPS_SIMULATE_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

// Adds the subcommand to `app`; when it is chosen, `*run` is set to the code
// that executes it and returns the process exit status.
void AddSimulateCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_SIMULATE_COMMAND_H_
