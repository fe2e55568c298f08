#include "io_drivers/transport_config.h"

#include <arpa/inet.h>

#include <cstdlib>
#include <filesystem>

#include "base/yaml_reader.h"

namespace kcrig {

Status LoadModbusSettings(const YamlReader& reader, const YAML::Node& root,
                          const std::string& directory, double period,
                          ModbusSettings* settings) {
  YAML::Node modbus, rtu;
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "modbus", &modbus));
  ModbusSettings& m = *settings;
  std::string map;
  KCRIG_RETURN_IF_ERROR(reader.String(modbus, "modbus", "map", &map));
  m.map_file = (std::filesystem::path(directory) / map).string();
  KCRIG_RETURN_IF_ERROR(reader.Positive(modbus, "modbus", "response_timeout",
                                        &m.response_timeout));
  if (m.response_timeout < 1e-5) {
    return reader.Error(modbus["response_timeout"], "modbus.response_timeout",
                        "must be >= 0.00001 s");
  }
  if (m.response_timeout > 0.5 * period) {
    return reader.Error(modbus["response_timeout"], "modbus.response_timeout",
                        "must be <= half of loop.period (a read and a write "
                        "share one cycle)");
  }
  KCRIG_RETURN_IF_ERROR(reader.InRange(modbus, "modbus", "reconnect_interval",
                                       0.01, 10, &m.reconnect_interval));
  KCRIG_RETURN_IF_ERROR(reader.Child(modbus, "modbus", "rtu", &rtu));
  KCRIG_RETURN_IF_ERROR(
      reader.Integer(rtu, "modbus.rtu", "baud", 300, 4000000, &m.baud));
  KCRIG_RETURN_IF_ERROR(
      reader.Integer(rtu, "modbus.rtu", "data_bits", 5, 8, &m.data_bits));
  KCRIG_RETURN_IF_ERROR(
      reader.Integer(rtu, "modbus.rtu", "stop_bits", 1, 2, &m.stop_bits));
  std::string parity_text;
  KCRIG_RETURN_IF_ERROR(
      reader.String(rtu, "modbus.rtu", "parity", &parity_text));
  if (parity_text != "N" && parity_text != "E" && parity_text != "O") {
    return reader.Error(rtu["parity"], "modbus.rtu.parity",
                        "must be N, E or O");
  }
  m.parity = parity_text[0];

  return Status::Ok();
}

Status LoadCanSettings(const YamlReader& reader, const YAML::Node& root,
                       const std::string& directory, double period,
                       CanSettings* settings) {
  YAML::Node can;
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "can", &can));
  CanSettings& c = *settings;
  std::string dbc;
  KCRIG_RETURN_IF_ERROR(reader.String(can, "can", "dbc", &dbc));
  c.dbc_file = (std::filesystem::path(directory) / dbc).string();
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(can, "can", "tx_timeout", &c.tx_timeout));
  if (c.tx_timeout < period || c.tx_timeout > 1) {
    return reader.Error(can["tx_timeout"], "can.tx_timeout",
                        "must be between loop.period and 1 s");
  }
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(can, "can", "connect_timeout", &c.connect_timeout));
  if (c.connect_timeout > 60) {
    return reader.Error(can["connect_timeout"], "can.connect_timeout",
                        "must be <= 60 s");
  }
  return Status::Ok();
}

Status ParseHostPort(const std::string& text, const std::string& form,
                     int min_port, std::string* host, int* port) {
  const size_t colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0) {
    return Status::Error("expected " + form);
  }
  const std::string port_text = text.substr(colon + 1);
  char* end = nullptr;
  const long value = std::strtol(port_text.c_str(), &end, 10);
  if (port_text.empty() || *end != '\0' || value < min_port || value > 65535) {
    return Status::Error("port '" + port_text + "' is not in " +
                         std::to_string(min_port) + "..65535");
  }
  *host = text.substr(0, colon);
  in_addr address;
  if (inet_pton(AF_INET, host->c_str(), &address) != 1) {
    return Status::Error("host '" + *host +
                         "' must be an IPv4 address (e.g. 127.0.0.1)");
  }
  *port = static_cast<int>(value);
  return Status::Ok();
}

}  // namespace kcrig
