#include "emulator/modbus_front_end.h"

#include "io_drivers/modbus_registers.h"
#include "io_drivers/modbus_server.h"
#include "rt_core/runtime/cycle_timer.h"

namespace kcrig {
namespace {

double Now() { return static_cast<double>(MonotonicNanoseconds()) * 1e-9; }

void PublishSample(const RigMeasurement& m, std::uint16_t sequence_echo,
                   const ModbusMap& map, std::uint16_t* input) {
  const bool order = map.high_word_first;
  input[map.status] = m.status;
  input[map.fault_code] = m.fault_code;
  PutUint32(m.sample, order, &input[map.sample]);
  input[map.sequence_echo] = sequence_echo;
  input[map.protocol] = kModbusProtocolVersion;
  for (int k = 0; k < 3; ++k)
    PutFloat32(m.force(k), order, &input[map.force[k]]);
  for (int k = 0; k < 6; ++k) PutFloat32(m.y(k), order, &input[map.y[k]]);
}

}  // namespace

Status ServeModbus(RigEmulator* rig, const ModbusMap& map,
                   const std::string& host, int port,
                   const std::atomic<int>& stop,
                   const std::function<void(int)>& on_listening) {
  ModbusServer server(map);
  Status status = server.Listen(host, port);
  if (!status.ok()) return status;
  status = rig->Start(Now());
  if (!status.ok()) return status;
  std::uint16_t* input = server.input_registers();
  std::uint16_t* holding = server.holding_registers();
  PublishSample(rig->TakeSample(), 0, map, input);
  on_listening(server.port());

  ModbusServer::Hooks hooks;
  hooks.tick = [rig] { rig->AdvanceTo(Now()); };
  hooks.before_input_read = [&] {
    rig->AdvanceTo(Now());
    PublishSample(rig->TakeSample(), rig->last_sequence(), map, input);
  };
  hooks.after_holding_write = [&] {
    const bool order = map.high_word_first;
    RigCommand command;
    const std::uint16_t control = holding[map.control_word];
    command.enable = (control & kControlEnable) != 0;
    command.sequence = holding[map.sequence];
    for (int k = 0; k < 3; ++k) {
      command.force(k) = GetFloat32(&holding[map.setpoint[k]], order);
    }
    command.z_a = GetFloat32(&holding[map.z_a], order);
    rig->ApplyCommand(command, (control & kControlResetFault) != 0);
  };
  return server.Serve(stop, 1e-3, hooks);
}

}  // namespace kcrig
