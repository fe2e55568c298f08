// kcrig emulate: the software rig as a separate process.
#ifndef KCRIG_APPS_EMULATE_COMMAND_H_
#define KCRIG_APPS_EMULATE_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddEmulateCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_EMULATE_COMMAND_H_
