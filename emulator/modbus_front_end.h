// The emulator's Modbus TCP front end: serves the register map of
// config/modbus_map.yaml for a RigEmulator. A read of the input registers
// takes a fresh sample (the rig samples on request, so the controller sees
// one new sample per cycle); a write of the holding registers is the
// command, obeyed only from the session in control (one master: the
// session, owner and refused_writes registers, rig_ownership.h); the plant
// advances in real time between requests (at least every millisecond).
#ifndef KCRIG_EMULATOR_MODBUS_FRONT_END_H_
#define KCRIG_EMULATOR_MODBUS_FRONT_END_H_

#include <atomic>
#include <functional>
#include <string>

#include "emulator/rig_emulator.h"
#include "io_drivers/modbus_map.h"

namespace kcrig {

// Listens on host:port (port 0 = any free port), calls `on_listening` with
// the port, serves until *stop is non-zero.
Status ServeModbus(RigEmulator* rig, const ModbusMap& map,
                   const std::string& host, int port,
                   const std::atomic<int>& stop,
                   const std::function<void(int)>& on_listening);

}  // namespace kcrig

#endif  // KCRIG_EMULATOR_MODBUS_FRONT_END_H_
