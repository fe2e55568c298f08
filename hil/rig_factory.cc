#include "hil/rig_factory.h"

#include <filesystem>

#include "io_drivers/can_rig.h"
#include "io_drivers/modbus_rig.h"
#include "records/can_bus_log.h"

namespace kcrig {

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
  status =
      CheckRtuWireTime(endpoint, map, rig_config.modbus, rig_config.period);
  if (!status.ok()) return status;
  *rig = std::make_unique<ModbusRig>(endpoint, map, rig_config.modbus);
  return Status::Ok();
}

}  // namespace kcrig
