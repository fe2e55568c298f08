// `kcrig report`: one self-contained HTML page with the plots of a
// campaign folder (and any diag.json / timing.json in it).
#ifndef KCRIG_APPS_REPORT_COMMAND_H_
#define KCRIG_APPS_REPORT_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddReportCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_REPORT_COMMAND_H_
