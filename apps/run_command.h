// kcrig run: one HIL experiment through a rig transport.
#ifndef KCRIG_APPS_RUN_COMMAND_H_
#define KCRIG_APPS_RUN_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddRunCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_RUN_COMMAND_H_
