// `kcrig estimate`: bushing stiffnesses (or any parameters) from run logs.
#ifndef KCRIG_APPS_ESTIMATE_COMMAND_H_
#define KCRIG_APPS_ESTIMATE_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddEstimateCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_ESTIMATE_COMMAND_H_
