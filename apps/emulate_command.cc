#include "apps/emulate_command.h"

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "apps/cli_util.h"
#include "apps/progress.h"
#include "emulator/can_front_end.h"
#include "emulator/modbus_front_end.h"
#include "emulator/plant_config.h"
#include "emulator/rig_emulator.h"
#include "hil/rig_config.h"
#include "io_drivers/modbus_map.h"
#include "io_drivers/transport_config.h"
#include "rt_core/model/model_config.h"
#include "rt_core/model/plant_effects.h"
#include "rt_core/runtime/clock.h"
#include "rt_core/runtime/realtime.h"

namespace kcrig {
namespace {

struct EmulateArgs {
  std::string config_dir;
  std::string modbus_tcp;
  std::string modbus_rtu;
  std::string can;
  std::vector<std::string> effects;
  std::optional<std::uint64_t> seed;
};

// What the emulator serves: the config, the true plant with its effects,
// rig.yaml, and for Modbus the map and where to serve it.
struct EmulatorSetUp {
  KcrigConfig config;
  PlantConfig plant;
  PlantEffects effects;
  RigConfig rig_config;
  ModbusMap map;
  ModbusServeAt at;
};

Status PrepareEmulator(const EmulateArgs& args, EmulatorSetUp* set_up) {
  if (!args.modbus_tcp.empty() + !args.modbus_rtu.empty() + !args.can.empty() !=
      1) {
    return Status::Error(
        "give one of --modbus-tcp HOST:PORT, --modbus-rtu DEVICE or --can "
        "IFACE");
  }
  ModbusServeAt& at = set_up->at;
  at.device = args.modbus_rtu;
  if (!args.modbus_tcp.empty()) {
    const Status status =
        ParseHostPort(args.modbus_tcp, "HOST:PORT", 0, &at.host, &at.port);
    if (!status.ok()) {
      return Status::Error("--modbus-tcp " + args.modbus_tcp + ": " +
                           status.message() + " (PORT 0 = any free port)");
    }
  }
  KcrigConfig& config = set_up->config;
  KCRIG_RETURN_IF_ERROR(LoadConfig(args.config_dir, &config));
  KCRIG_RETURN_IF_ERROR(
      LoadPlantConfig(config.directory, config.model, &set_up->plant));
  if (args.seed) set_up->plant.seed = *args.seed;
  KCRIG_RETURN_IF_ERROR(LoadRigConfig(config.directory, &set_up->rig_config));
  if (args.can.empty()) {
    KCRIG_RETURN_IF_ERROR(
        LoadModbusMap(set_up->rig_config.modbus.map_file, &set_up->map));
    at.serial = set_up->rig_config.modbus;
  }
  set_up->effects = set_up->plant.effects;
  for (const std::string& effect : args.effects) {
    const Status status = ParseEffect(effect, &set_up->effects);
    if (!status.ok()) return Status::Error("--effect " + status.message());
  }
  return Status::Ok();
}

Status EmulateOnCan(const EmulateArgs& args, const EmulatorSetUp& set_up,
                    const std::string& effect_text, RigEmulator* rig,
                    const std::atomic<int>& stop) {
  const MonotonicClock clock;
  const std::string& dbc = set_up.rig_config.can.dbc_file;
  CanNodeCounters counters;
  KCRIG_RETURN_IF_ERROR(ServeCan(
      rig, clock, dbc, args.can, stop,
      [&] {
        std::printf(
            "kcrig emulate: on can:%s (DBC %s); true plant from "
            "plant.yaml, effects: %s\n",
            args.can.c_str(), dbc.c_str(), effect_text.c_str());
        std::fflush(stdout);
      },
      &counters));
  std::printf(
      "kcrig emulate: stopped (signal %d); commands %lld, samples sent "
      "%lld, heartbeats %lld, malformed frames %lld, refused frames "
      "%lld, send failures %lld\n",
      stop.load(), static_cast<long long>(counters.commands),
      static_cast<long long>(counters.samples_sent),
      static_cast<long long>(counters.heartbeats),
      static_cast<long long>(counters.malformed),
      static_cast<long long>(counters.refused),
      static_cast<long long>(counters.send_failures));
  return Status::Ok();
}

Status EmulateOnModbus(const EmulatorSetUp& set_up,
                       const std::string& effect_text, RigEmulator* rig,
                       const std::atomic<int>& stop) {
  const MonotonicClock clock;
  KCRIG_RETURN_IF_ERROR(ServeModbus(
      rig, clock, set_up.map, set_up.at, stop,
      [&](const std::string& uri) {
        std::printf(
            "kcrig emulate: serving %s (unit %d, map %s); true plant from "
            "plant.yaml, effects: %s\n",
            uri.c_str(), set_up.map.unit_id,
            set_up.rig_config.modbus.map_file.c_str(), effect_text.c_str());
        std::fflush(stdout);
      },
      [](const std::string& line) {
        std::fprintf(stderr, "kcrig emulate: %s\n", line.c_str());
      }));
  std::printf("kcrig emulate: stopped (signal %d)\n", stop.load());
  return Status::Ok();
}

int RunEmulate(const EmulateArgs& args) {
  const CommandError fail("emulate");
  EmulatorSetUp set_up;
  Status status = PrepareEmulator(args, &set_up);
  if (!status.ok()) return fail(status);
  // A real rig's servo controller is real-time too; without it the
  // controller sees more late replies. Refusal is a warning, not an error.
  RealtimeOptions realtime;
  realtime.priority = set_up.plant.priority;
  realtime.cpu = set_up.plant.cpu;
  for (const std::string& warning : SetUpRealtime(realtime).warnings) {
    std::fprintf(stderr, "kcrig emulate: warning: %s\n", warning.c_str());
  }
  const std::atomic<int>& stop = InstallStopSignalHandlers();
  RigEmulator rig(set_up.config, set_up.plant, set_up.effects);
  // SIGUSR1 presses the rig's emergency stop (a rehearsal of a rig-side
  // fault: kill -USR1 PID), SIGUSR2 releases it.
  rig.WireEmergencyStop(&EmergencyStopButton());
  std::string effect_text;
  for (const std::string& e : DescribeEffects(set_up.effects)) {
    effect_text += (effect_text.empty() ? "" : " ") + e;
  }
  if (effect_text.empty()) effect_text = "none";
  status = args.can.empty()
               ? EmulateOnModbus(set_up, effect_text, &rig, stop)
               : EmulateOnCan(args, set_up, effect_text, &rig, stop);
  return status.ok() ? 0 : fail(status);
}

}  // namespace

void AddEmulateCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<EmulateArgs>();
  CLI::App* cmd = app->add_subcommand(
      "emulate",
      "The software rig: hydraulic actuator, true plant with optional "
      "unmodelled effects, sensors, served over Modbus TCP or RTU or as a "
      "CAN node until SIGINT/SIGTERM");
  cmd->add_option("--config", args->config_dir,
                  "Config directory (default: installed or source config/)");
  cmd->add_option("--modbus-tcp", args->modbus_tcp,
                  "Serve Modbus TCP on HOST:PORT (PORT 0: any free port, "
                  "printed on start)");
  cmd->add_option("--modbus-rtu", args->modbus_rtu,
                  "Serve Modbus RTU on this serial device (line settings "
                  "from rig.yaml modbus.rtu)");
  cmd->add_option("--can", args->can,
                  "Be the rig's CAN node on this SocketCAN interface (e.g. "
                  "vcan0), speaking config/kc_rig.dbc");
  cmd->add_option("--effect", args->effects,
                  "Unmodelled effect of the true plant, NAME[:k=v,...] "
                  "(repeatable; as kcrig simulate)");
  cmd->add_option_function<std::uint64_t>(
      "--seed", [args](const std::uint64_t& seed) { args->seed = seed; },
      "Sensor-noise seed (default: plant.yaml)");
  cmd->callback([args, run] { *run = [args] { return RunEmulate(*args); }; });
}

}  // namespace kcrig
