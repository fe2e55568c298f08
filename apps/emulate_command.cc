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

int RunEmulate(const EmulateArgs& args) {
  const CommandError fail("emulate");
  if (!args.modbus_tcp.empty() + !args.modbus_rtu.empty() + !args.can.empty() !=
      1) {
    return fail(
        Status::Error("give one of --modbus-tcp HOST:PORT, --modbus-rtu "
                      "DEVICE or --can IFACE"));
  }
  ModbusServeAt at;
  at.device = args.modbus_rtu;
  Status status = Status::Ok();
  if (!args.modbus_tcp.empty()) {
    status = ParseHostPort(args.modbus_tcp, "HOST:PORT", 0, &at.host, &at.port);
    if (!status.ok()) {
      return fail(Status::Error("--modbus-tcp " + args.modbus_tcp + ": " +
                                status.message() +
                                " (PORT 0 = any free port)"));
    }
  }
  KcrigConfig config;
  status = LoadConfig(args.config_dir, &config);
  if (!status.ok()) return fail(status);
  PlantConfig plant;
  status = LoadPlantConfig(config.directory, config.model, &plant);
  if (!status.ok()) return fail(status);
  if (args.seed) plant.seed = *args.seed;
  RigConfig rig_config;
  status = LoadRigConfig(config.directory, &rig_config);
  if (!status.ok()) return fail(status);
  ModbusMap map;
  if (args.can.empty()) {
    status = LoadModbusMap(rig_config.modbus.map_file, &map);
    if (!status.ok()) return fail(status);
    at.serial = rig_config.modbus;
  }
  PlantEffects effects = plant.effects;
  for (const std::string& effect : args.effects) {
    status = ParseEffect(effect, &effects);
    if (!status.ok())
      return fail(Status::Error("--effect " + status.message()));
  }

  // A real rig's servo controller is real-time too; without it the
  // controller sees more late replies. Refusal is a warning, not an error.
  RealtimeOptions realtime;
  realtime.priority = plant.priority;
  realtime.cpu = plant.cpu;
  for (const std::string& warning : SetUpRealtime(realtime).warnings) {
    std::fprintf(stderr, "kcrig emulate: warning: %s\n", warning.c_str());
  }
  const std::atomic<int>& stop = InstallStopSignalHandlers();
  RigEmulator rig(config, plant, effects);
  // SIGUSR1 presses the rig's emergency stop (a rehearsal of a rig-side
  // fault: kill -USR1 PID), SIGUSR2 releases it.
  rig.WireEmergencyStop(&EmergencyStopButton());
  const MonotonicClock clock;
  std::string effect_text;
  for (const std::string& e : DescribeEffects(effects)) {
    effect_text += (effect_text.empty() ? "" : " ") + e;
  }
  if (!args.can.empty()) {
    CanNodeCounters counters;
    status = ServeCan(
        &rig, clock, rig_config.can.dbc_file, args.can, stop,
        [&] {
          std::printf(
              "kcrig emulate: on can:%s (DBC %s); true plant from "
              "plant.yaml, effects: %s\n",
              args.can.c_str(), rig_config.can.dbc_file.c_str(),
              effect_text.empty() ? "none" : effect_text.c_str());
          std::fflush(stdout);
        },
        &counters);
    if (!status.ok()) return fail(status);
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
    return 0;
  }
  status = ServeModbus(
      &rig, clock, map, at, stop,
      [&](const std::string& uri) {
        std::printf(
            "kcrig emulate: serving %s (unit %d, map %s); true plant from "
            "plant.yaml, effects: %s\n",
            uri.c_str(), map.unit_id, rig_config.modbus.map_file.c_str(),
            effect_text.empty() ? "none" : effect_text.c_str());
        std::fflush(stdout);
      },
      [](const std::string& line) {
        std::fprintf(stderr, "kcrig emulate: %s\n", line.c_str());
      });
  if (!status.ok()) return fail(status);
  std::printf("kcrig emulate: stopped (signal %d)\n", stop.load());
  return 0;
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
