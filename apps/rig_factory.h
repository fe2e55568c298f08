// The rig transports the command line can name, behind RigInterface, and the
// SIGINT/SIGTERM handling that turns a signal into a safe ramp-down.
#ifndef KCRIG_APPS_RIG_FACTORY_H_
#define KCRIG_APPS_RIG_FACTORY_H_

#include <atomic>
#include <memory>
#include <string>

#include "io_drivers/config_loader.h"
#include "rt_core/rig_interface.h"

namespace kcrig {

// modbus-tcp://HOST:PORT or modbus-rtu://DEVICE (can:IFACE comes with the
// SocketCAN transport). The rig is created, not configured.
Status MakeRig(const std::string& uri, const RigConfig& rig_config,
               std::unique_ptr<RigInterface>* rig);

// Installs handlers for SIGINT and SIGTERM that store the signal number in
// the returned flag (the loop ramps down when it is non-zero).
const std::atomic<int>& InstallStopSignalHandlers();

}  // namespace kcrig

#endif  // KCRIG_APPS_RIG_FACTORY_H_
