#include "hil/rig_factory.h"

#include <csignal>
#include <filesystem>

#include "io_drivers/can_rig.h"
#include "io_drivers/modbus_rig.h"
#include "records/can_bus_log.h"

namespace kcrig {
namespace {

std::atomic<int> g_stop_signal{0};
static_assert(std::atomic<int>::is_always_lock_free,
              "the signal handler stores into it");

extern "C" void OnStopSignal(int signal) { g_stop_signal.store(signal); }

}  // namespace

Status MakeRig(const std::string& uri, const RigConfig& rig_config,
               const std::string& log_dir, std::unique_ptr<RigInterface>* rig) {
  if (uri.rfind("can:", 0) == 0) {
    CanRigOptions options;
    Status status = ParseCanUri(uri, &options.interface);
    if (!status.ok()) return status;
    options.settings = rig_config.can;
    options.period = rig_config.period;
    if (!log_dir.empty()) {
      options.bus_log = std::make_unique<CanBusLog>(
          (std::filesystem::path(log_dir) / "can.log").string());
    }
    *rig = std::make_unique<CanRig>(std::move(options));
    return Status::Ok();
  }
  ModbusEndpoint endpoint;
  Status status = ParseModbusUri(uri, &endpoint);
  if (!status.ok()) return status;
  ModbusMap map;
  status = LoadModbusMap(rig_config.modbus.map_file, &map);
  if (!status.ok()) return status;
  *rig = std::make_unique<ModbusRig>(endpoint, map, rig_config.modbus);
  return Status::Ok();
}

const std::atomic<int>& InstallStopSignalHandlers() {
  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  // The first signal asks for the ramp-down; a second one acts as usual.
  action.sa_flags = SA_RESETHAND;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
  return g_stop_signal;
}

}  // namespace kcrig
