// A Modbus TCP or RTU server (libmodbus) holding the register map's two
// tables, for the rig side: the emulator's front end. Over RTU it serves
// the one master of its serial line (client 1); a frame with a bad CRC or
// cut short is dropped (the master times out). Over TCP it serves several
// clients (the controller, mbpoll, ...) from one thread with poll() and
// never blocks on one of them: each connection has its own receive buffer,
// a request is answered once its whole frame has arrived, and a frame left
// unfinished for kPartialFrameTimeout or a malformed header closes that
// connection only. Connections are bounded so that idle ones cannot lock
// the master out (16 clients at work can: the new one is then closed at
// once, and says why): one without a whole request for kIdleTimeout is
// closed, and
// a new connection beyond kMaxClients takes the place of the longest idle
// one if that one has been idle for kEvictableIdle (a flood of new
// connections cannot push out a client at work), never of a protected one
// (the owner's); otherwise the new one is closed at once. The owner's hooks run
// on every wake-up (advance the plant, at least every tick interval), before an
// input-register read is answered (take a sample, for that client) and a
// holding-register read (what that client may see of the table), before a
// holding-register write is applied (accept it, or refuse it with exception 6,
// server busy) and when a client's connection closes.
#ifndef KCRIG_IO_DRIVERS_MODBUS_SERVER_H_
#define KCRIG_IO_DRIVERS_MODBUS_SERVER_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

#include "base/status.h"
#include "io_drivers/modbus_map.h"
#include "io_drivers/transport_config.h"

typedef struct _modbus modbus_t;
typedef struct _modbus_mapping_t modbus_mapping_t;

namespace kcrig {

class ModbusServer {
 public:
  static constexpr int kMaxClients = 16;
  static constexpr double kPartialFrameTimeout = 0.5;  // [s]
  static constexpr double kIdleTimeout = 10.0;         // [s]
  static constexpr double kEvictableIdle = 1.0;        // [s]

  // `client` identifies a connection for as long as the server runs (ids
  // are never reused). `values` are the registers a write request carries,
  // starting at `address`.
  struct Hooks {
    std::function<void()> tick;
    std::function<void(int client)> before_input_read;
    std::function<void(int client)> before_holding_read;
    std::function<bool(int client, int address, int count,
                       const std::uint16_t* values)>
        accept_holding_write;
    std::function<void(int client)> client_closed;
    // A connection never closed for idleness or room (the owner's).
    std::function<bool(int client)> is_protected;
    // One line on what the server did to a connection (for the log).
    std::function<void(const std::string& line)> note;
  };

  explicit ModbusServer(const ModbusMap& map);
  ~ModbusServer();
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;

  // Binds and listens; port 0 picks a free port (see port()).
  Status Listen(const std::string& host, int port);
  int port() const { return port_; }
  // Opens the serial device with `serial`'s line settings (baud, parity,
  // data and stop bits) instead.
  Status OpenSerial(const std::string& device, const ModbusSettings& serial);

  // Serves until *stop is non-zero.
  Status Serve(const std::atomic<int>& stop, double tick_interval,
               const Hooks& hooks);

  std::uint16_t* input_registers();
  std::uint16_t* holding_registers();

 private:
  Status ServeSerial(const std::atomic<int>& stop, double tick_interval,
                     const Hooks& hooks);

  ModbusMap map_;
  std::string device_;  // RTU: the serial device
  modbus_t* context_ = nullptr;
  modbus_mapping_t* mapping_ = nullptr;
  int listen_socket_ = -1;
  int port_ = 0;
};

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_MODBUS_SERVER_H_
