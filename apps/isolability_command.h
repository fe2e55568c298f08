// `kcrig isolability`: which faults a plan of experiments can tell apart,
// before it is run (diagnosis/isolability.h).
#ifndef KCRIG_APPS_ISOLABILITY_COMMAND_H_
#define KCRIG_APPS_ISOLABILITY_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddIsolabilityCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_ISOLABILITY_COMMAND_H_
