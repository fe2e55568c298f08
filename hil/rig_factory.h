// The rig transports the command line can name, behind RigInterface, and the
// SIGINT/SIGTERM handling that turns a signal into a safe ramp-down.
#ifndef KCRIG_HIL_RIG_FACTORY_H_
#define KCRIG_HIL_RIG_FACTORY_H_

#include <memory>
#include <string>

#include "hil/rig_config.h"
#include "rt_core/runtime/rig_interface.h"

namespace kcrig {

// modbus-tcp://HOST:PORT, modbus-rtu://DEVICE or can:IFACE. The rig is
// created, not configured. A CAN rig writes its bus log to
// `log_dir`/can.log (none when `log_dir` is empty).
Status MakeRig(const std::string& uri, const RigConfig& rig_config,
               const std::string& log_dir, std::unique_ptr<RigInterface>* rig);

}  // namespace kcrig

#endif  // KCRIG_HIL_RIG_FACTORY_H_
