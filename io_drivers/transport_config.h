// The transports' settings in rig.yaml (modbus, can), loaded and
// range-checked by the library that uses them.
#ifndef KCRIG_IO_DRIVERS_TRANSPORT_CONFIG_H_
#define KCRIG_IO_DRIVERS_TRANSPORT_CONFIG_H_

#include <string>

#include "base/status.h"

namespace YAML {
class Node;
}

namespace kcrig {

class YamlReader;

// The Modbus transport (rig.yaml `modbus:`).
struct ModbusSettings {
  std::string map_file;             // absolute path of the register map
  double response_timeout = 4e-4;   // [s]
  double reconnect_interval = 0.1;  // [s]
  int baud = 115200;                // RTU
  char parity = 'N';
  int data_bits = 8;
  int stop_bits = 1;
};

// The SocketCAN transport (rig.yaml `can:`).
struct CanSettings {
  std::string dbc_file;  // absolute path of the protocol's DBC
  // The transmit queue may stay full (ENOBUFS) this long before it is a
  // fault (tx timeout) [s].
  double tx_timeout = 0.02;
  // Configure waits this long for the rig's first heartbeat [s].
  double connect_timeout = 1.0;
};

// Reads `root`'s section modbus (the map's path relative to `directory`);
// the response timeout must fit half of the loop's `period`.
Status LoadModbusSettings(const YamlReader& reader, const YAML::Node& root,
                          const std::string& directory, double period,
                          ModbusSettings* settings);

// Reads `root`'s section can (the DBC's path relative to `directory`).
Status LoadCanSettings(const YamlReader& reader, const YAML::Node& root,
                       const std::string& directory, double period,
                       CanSettings* settings);

// "HOST:PORT" with an IPv4 HOST and a PORT in [min_port, 65535] (0 lets a
// server take any free port). The error says what is wrong ("expected
// `form`" when there is no HOST:PORT at all); the caller names the option.
Status ParseHostPort(const std::string& text, const std::string& form,
                     int min_port, std::string* host, int* port);

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_TRANSPORT_CONFIG_H_
