// `kcrig validate`: how well kcrig diagnoses this configuration — blind
// cases simulated, diagnosed and scored against their truth; spread over
// MPI ranks under mpirun.
#ifndef KCRIG_APPS_VALIDATE_COMMAND_H_
#define KCRIG_APPS_VALIDATE_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddValidateCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_VALIDATE_COMMAND_H_
