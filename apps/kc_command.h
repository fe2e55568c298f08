// `kcrig kc`: the K&C sheet of run logs (compliance gradients, hysteresis,
// model vs rig).
#ifndef KCRIG_APPS_KC_COMMAND_H_
#define KCRIG_APPS_KC_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddKcCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_KC_COMMAND_H_
