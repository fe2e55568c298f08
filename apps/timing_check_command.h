// kcrig timing-check: the loop's timing against its budget and the machine's
// baseline.
#ifndef KCRIG_APPS_TIMING_CHECK_COMMAND_H_
#define KCRIG_APPS_TIMING_CHECK_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddTimingCheckCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_TIMING_CHECK_COMMAND_H_
