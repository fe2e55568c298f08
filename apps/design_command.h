// kcrig design: optimal experimental design for the next ramp experiment.
#ifndef KCRIG_APPS_DESIGN_COMMAND_H_
#define KCRIG_APPS_DESIGN_COMMAND_H_

#include <functional>
#include <string>

#include "CLI/CLI.hpp"
#include "designer/design_objective.h"
#include "designer/optimizers.h"

namespace kcrig {

void AddDesignCommand(CLI::App* app, std::function<int()>* run);

// "kriging: 24/100 evaluations, best D -77.1058 at 16.0 deg, -0.500 m, 0.7 s"
// for the objective's progress callback.
std::string DesignProgressText(const std::string& optimizer,
                               const DesignObjective& objective);

}  // namespace kcrig

#endif  // KCRIG_APPS_DESIGN_COMMAND_H_
