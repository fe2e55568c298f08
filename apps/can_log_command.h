// kcrig can-log: kcrig's own bus logger (candump -l format), with the same
// socket and log writer as a CAN run's can.log.
#ifndef KCRIG_APPS_CAN_LOG_COMMAND_H_
#define KCRIG_APPS_CAN_LOG_COMMAND_H_

#include <functional>

#include "CLI/CLI.hpp"

namespace kcrig {

void AddCanLogCommand(CLI::App* app, std::function<int()>* run);

}  // namespace kcrig

#endif  // KCRIG_APPS_CAN_LOG_COMMAND_H_
