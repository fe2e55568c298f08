// kcrig design: optimal experimental design for the next ramp experiment.
#ifndef KCRIG_APPS_DESIGN_COMMAND_H_
#define KCRIG_APPS_DESIGN_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddDesignCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_DESIGN_COMMAND_H_
