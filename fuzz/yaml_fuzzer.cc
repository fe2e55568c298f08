// The config loaders on any text: model.yaml, experiment.yaml, the Modbus
// register map, rig.yaml or plant.yaml (the first byte picks which; the
// others are the source config's). An error, or a config every value of
// which is finite, within its documented range, and that passes its own
// validation again.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "emulator/plant_config.h"
#include "hil/rig_config.h"
#include "io_drivers/modbus_map.h"
#include "rt_core/model/model_config.h"

namespace {

namespace fs = std::filesystem;

// A config directory of this process with the source config in it.
const fs::path& Directory() {
  static const fs::path directory = [] {
    const fs::path d = fs::temp_directory_path() /
                       ("kcrig_yaml_fuzz_" + std::to_string(getpid()));
    fs::create_directories(d);
    for (const char* name : {"model.yaml", "experiment.yaml", "modbus_map.yaml",
                             "rig.yaml", "plant.yaml", "kc_rig.dbc"}) {
      fs::copy_file(fs::path(KCRIG_CONFIG_DIR) / name, d / name,
                    fs::copy_options::overwrite_existing);
    }
    return d;
  }();
  return directory;
}

void Write(const fs::path& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data),
             static_cast<std::streamsize>(size));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  if (size == 0) return 0;
  const int which = data[0] % 5;
  const char* names[] = {"model.yaml", "experiment.yaml", "modbus_map.yaml",
                         "rig.yaml", "plant.yaml"};
  const fs::path file = Directory() / names[which];
  const fs::path saved = Directory() / "saved";
  fs::copy_file(file, saved, fs::copy_options::overwrite_existing);
  Write(file, data + 1, size - 1);
  if (which == 2) {
    kcrig::ModbusMap map;
    if (kcrig::LoadModbusMap(file.string(), &map).ok() &&
        (map.input_count() > 125 || map.holding_count() > 123)) {
      abort();
    }
  } else if (which == 3) {
    kcrig::RigConfig rig;
    if (kcrig::LoadRigConfig(Directory().string(), &rig).ok() &&
        (!(rig.period >= 1e-4 && rig.period <= 0.1) ||
         !(rig.safety.force_max > 0 && rig.safety.force_max <= 1e5) ||
         !(rig.safety.ramp_down_time > 0 && rig.safety.ramp_down_time <= 10) ||
         !(rig.budget.wakeup_p99 > 0 && rig.budget.wakeup_p99 <= 1) ||
         !(rig.modbus.reconnect_interval <= 10))) {
      abort();
    }
  } else if (which == 4) {
    kcrig::KcrigConfig config;
    kcrig::PlantConfig plant;
    if (kcrig::LoadConfig(Directory().string(), &config).ok() &&
        kcrig::LoadPlantConfig(Directory().string(), config.model, &plant)
            .ok() &&
        (!(plant.actuator_force_max > 0 && plant.actuator_force_max <= 1e5) ||
         !(plant.load_cell_sigma >= 0 && plant.load_cell_sigma <= 1e3) ||
         !(plant.claim_timeout >= plant.command_timeout) ||
         !kcrig::ValidateModel(plant.model, "again").ok())) {
      abort();
    }
  } else {
    kcrig::KcrigConfig config;
    if (kcrig::LoadConfig(Directory().string(), &config).ok()) {
      if (!kcrig::ValidateModel(config.model, "again").ok()) abort();
      const kcrig::ExperimentConfig& e = config.experiment;
      if (!std::isfinite(e.phi) || !std::isfinite(e.z_a) || !(e.fmax > 0) ||
          !(e.rate > 0) || !(e.step > 0) ||
          !(e.duration > 0 && e.duration <= 3600)) {
        abort();
      }
    }
  }
  fs::copy_file(saved, file, fs::copy_options::overwrite_existing);
  return 0;
}
