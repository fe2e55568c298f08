// `kcrig export`: a run log in another format (MATLAB MAT-file or run.csv).
#ifndef KCRIG_APPS_EXPORT_COMMAND_H_
#define KCRIG_APPS_EXPORT_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddExportCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_EXPORT_COMMAND_H_
