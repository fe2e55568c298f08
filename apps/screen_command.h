// `kcrig screen`: screening of candidate parameters (paper section 3.2).
#ifndef KCRIG_APPS_SCREEN_COMMAND_H_
#define KCRIG_APPS_SCREEN_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddScreenCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_SCREEN_COMMAND_H_
