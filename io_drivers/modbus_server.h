// A Modbus TCP server (libmodbus) holding the register map's two tables, for
// the rig side: the emulator's front end. Serves any number of clients (the
// controller, mbpoll, ...) from one thread with select(); the owner's hooks
// run before an input-register read is answered (take a sample), after a
// holding-register write was applied (take the command), and on every wake-up
// (advance the plant), at least every tick interval.
#ifndef KCRIG_IO_DRIVERS_MODBUS_SERVER_H_
#define KCRIG_IO_DRIVERS_MODBUS_SERVER_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

#include "base/status.h"
#include "io_drivers/modbus_map.h"

typedef struct _modbus modbus_t;
typedef struct _modbus_mapping_t modbus_mapping_t;

namespace kcrig {

class ModbusServer {
 public:
  struct Hooks {
    std::function<void()> tick;
    std::function<void()> before_input_read;
    std::function<void()> after_holding_write;
  };

  explicit ModbusServer(const ModbusMap& map);
  ~ModbusServer();
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;

  // Binds and listens; port 0 picks a free port (see port()).
  Status Listen(const std::string& host, int port);
  int port() const { return port_; }

  // Serves until *stop is non-zero.
  Status Serve(const std::atomic<int>& stop, double tick_interval,
               const Hooks& hooks);

  std::uint16_t* input_registers();
  std::uint16_t* holding_registers();

 private:
  ModbusMap map_;
  modbus_t* context_ = nullptr;
  modbus_mapping_t* mapping_ = nullptr;
  int listen_socket_ = -1;
  int port_ = 0;
};

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_MODBUS_SERVER_H_
