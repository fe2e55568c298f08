#include "emulator/modbus_front_end.h"

#include <algorithm>

#include "io_drivers/modbus_registers.h"
#include "io_drivers/modbus_server.h"

namespace kcrig {
namespace {

// The sample as `client` reads it: only the owner's connection is told the
// owner's token.
void PublishSample(const RigMeasurement& m, const RigEmulator& rig,
                   const ModbusMap& map, int client, std::uint16_t* input) {
  const bool order = map.high_word_first;
  input[map.status] = m.status;
  input[map.fault_code] = m.fault_code;
  PutUint32(m.sample, order, &input[map.sample]);
  input[map.sequence_echo] = rig.last_sequence();
  input[map.protocol] = kModbusProtocolVersion;
  input[map.owner] = rig.ownership().VisibleOwner(client);
  input[map.refused_writes] = rig.ownership().refused();
  for (int k = 0; k < 3; ++k)
    PutFloat32(m.force(k), order, &input[map.force[k]]);
  for (int k = 0; k < 6; ++k) PutFloat32(m.y(k), order, &input[map.y[k]]);
}

// What a holding-register write asks of the rig: the table as it would be
// after the write, and whether the request itself carries a session.
RigRequest DecodeWrite(const ModbusMap& map, const std::uint16_t* holding,
                       int address, int count, const std::uint16_t* values,
                       int connection) {
  std::uint16_t after[128] = {};
  const int size = map.holding_count();
  std::copy(holding, holding + size, after);
  for (int k = 0; k < count; ++k) {
    if (address + k >= 0 && address + k < size) after[address + k] = values[k];
  }
  const bool order = map.high_word_first;
  const std::uint16_t control = after[map.control_word];
  RigRequest request;
  request.command.enable = (control & kControlEnable) != 0;
  request.command.sequence = after[map.sequence];
  for (int k = 0; k < 3; ++k) {
    request.command.force(k) = GetFloat32(&after[map.setpoint[k]], order);
  }
  request.command.z_a = GetFloat32(&after[map.z_a], order);
  request.reset_fault = (control & kControlResetFault) != 0;
  RigOwnership::Request& o = request.ownership;
  o.has_session = map.session >= address && map.session < address + count;
  o.session = after[map.session];
  o.claim = (control & kControlClaim) != 0;
  o.release = (control & kControlRelease) != 0;
  o.enable = request.command.enable;
  o.connection = connection;
  return request;
}

}  // namespace

Status ServeModbus(RigEmulator* rig, const Clock& clock, const ModbusMap& map,
                   const ModbusServeAt& at, const std::atomic<int>& stop,
                   const std::function<void(const std::string&)>& on_ready,
                   const std::function<void(const std::string&)>& on_note) {
  ModbusServer server(map);
  Status status = at.device.empty() ? server.Listen(at.host, at.port)
                                    : server.OpenSerial(at.device, at.serial);
  if (!status.ok()) return status;
  status = rig->Start(clock.Seconds());
  if (!status.ok()) return status;
  std::uint16_t* input = server.input_registers();
  std::uint16_t* holding = server.holding_registers();
  PublishSample(rig->TakeSample(), *rig, map, /*client=*/-1, input);
  on_ready(at.device.empty()
               ? "modbus-tcp://" + at.host + ":" + std::to_string(server.port())
               : "modbus-rtu://" + at.device);

  ModbusServer::Hooks hooks;
  hooks.tick = [rig, &clock] { rig->AdvanceTo(clock.Seconds()); };
  hooks.before_input_read = [&](int client) {
    rig->AdvanceTo(clock.Seconds());
    PublishSample(rig->TakeSample(), *rig, map, client, input);
  };
  // A refused write leaves the table as it was; the owner and the refusal
  // count reach the input registers with the next sample.
  hooks.accept_holding_write = [&](int connection, int address, int count,
                                   const std::uint16_t* values) {
    // Beyond the table the server answers "illegal address" and applies
    // nothing: not the rig's to refuse.
    if (address < 0 || address + count > map.holding_count()) return true;
    rig->AdvanceTo(clock.Seconds());
    return rig->Request(
        DecodeWrite(map, holding, address, count, values, connection));
  };
  hooks.client_closed = [rig, &clock](int connection) {
    rig->AdvanceTo(clock.Seconds());
    rig->ConnectionClosed(connection);
  };
  // The owner's token stays in the holding table (its writes put it
  // there), but only the owner's connection reads it back.
  hooks.before_holding_read = [&](int client) {
    holding[map.session] = rig->ownership().VisibleOwner(client);
  };
  hooks.is_protected = [rig](int client) {
    return rig->ownership().IsOwnerConnection(client);
  };
  hooks.note = on_note;
  return server.Serve(stop, 1e-3, hooks);
}

}  // namespace kcrig
