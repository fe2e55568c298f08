// The Modbus register map of the rig (config/modbus_map.yaml) and the
// control word's bits: the contract a rig's Modbus front end implements.
#ifndef KCRIG_IO_DRIVERS_MODBUS_MAP_H_
#define KCRIG_IO_DRIVERS_MODBUS_MAP_H_

#include <cstdint>
#include <string>

#include "base/status.h"

namespace kcrig {

// The Modbus register map (config/modbus_map.yaml): 0-based addresses;
// float32 and uint32 take two registers, high word first unless
// `high_word_first` is false.
struct ModbusMap {
  int unit_id = 1;
  bool high_word_first = true;
  // Holding registers (controller -> rig).
  int control_word = 0, sequence = 1;
  int setpoint[3] = {2, 4, 6};
  int z_a = 8;
  int session = 10;  // the writer's session token, in every write
  // Input registers (rig -> controller).
  int status = 0, fault_code = 1, sample = 2, sequence_echo = 4, protocol = 5;
  int force[3] = {6, 8, 10};
  int y[6] = {12, 14, 16, 18, 20, 22};
  int owner = 24;  // the session in control (to its own connection; 0xffff
                   // to others while claimed), 0 = none
  int refused_writes = 25;  // writes the rig refused, mod 2^16
  // One past the highest register used, per table.
  int holding_count() const;
  int input_count() const;
};

// Control word bits and the map's protocol version. One master at a time
// (docs/rig.md, Modbus): a write with `claim` and a session token (not 0 or
// kOwnerHidden) takes an unclaimed rig; while claimed, the rig obeys only
// writes that carry the owner's token in the same request on the
// connection that claimed (others get exception 6, server busy), and tells
// the token to that connection only (others read kOwnerHidden); `release`,
// the owner's silence for the rig's claim timeout or its connection
// closing end the claim. An unclaimed rig is never enabled.
inline constexpr std::uint16_t kControlEnable = 1u << 0;
inline constexpr std::uint16_t kControlResetFault = 1u << 1;
inline constexpr std::uint16_t kControlClaim = 1u << 2;
inline constexpr std::uint16_t kControlRelease = 1u << 3;
// 2: the session, owner and refused_writes registers (one master); 3: the
// claim bound to its connection, the token told only to it.
inline constexpr std::uint16_t kModbusProtocolVersion = 3;

Status LoadModbusMap(const std::string& file, ModbusMap* map);

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_MODBUS_MAP_H_
