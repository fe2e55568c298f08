// The emulator's Modbus TCP or RTU front end: serves the register map of
// config/modbus_map.yaml for a RigEmulator. A read of the input registers
// takes a fresh sample (the rig samples on request, so the controller sees
// one new sample per cycle); a write of the holding registers is the
// command, obeyed only from the session in control (one master: the
// session, owner and refused_writes registers, rig_ownership.h: a write
// is the owner's only on the owner's connection, and only that connection
// reads the owner's token, others 0xffff); the plant
// advances to the clock's time between requests (at least every
// millisecond) and before each is answered.
#ifndef KCRIG_EMULATOR_MODBUS_FRONT_END_H_
#define KCRIG_EMULATOR_MODBUS_FRONT_END_H_

#include <atomic>
#include <functional>
#include <string>

#include "emulator/rig_emulator.h"
#include "io_drivers/modbus_map.h"
#include "io_drivers/transport_config.h"
#include "rt_core/runtime/clock.h"

namespace kcrig {

// Where the front end serves: TCP on host:port (port 0 = any free port),
// or RTU on a serial device (non-empty `device`, line settings `serial`).
struct ModbusServeAt {
  std::string host;
  int port = 0;
  std::string device;
  ModbusSettings serial;
};

// Opens `at`, calls `on_ready` with its URI (modbus-tcp://HOST:PORT with
// the bound port, or modbus-rtu://DEVICE), serves until *stop is non-zero;
// `on_note` gets a line whenever the server closes a client for idleness
// or room (may be empty).
Status ServeModbus(RigEmulator* rig, const Clock& clock, const ModbusMap& map,
                   const ModbusServeAt& at, const std::atomic<int>& stop,
                   const std::function<void(const std::string&)>& on_ready,
                   const std::function<void(const std::string&)>& on_note);

}  // namespace kcrig

#endif  // KCRIG_EMULATOR_MODBUS_FRONT_END_H_
