// Loads and validates kcrig's YAML configuration (config/model.yaml and
// config/experiment.yaml). Every error is one line naming the file, the line
// and the key, e.g. "config/model.yaml:14: bushings.O1.stiffness: must be > 0".
#ifndef KCRIG_IO_DRIVERS_CONFIG_LOADER_H_
#define KCRIG_IO_DRIVERS_CONFIG_LOADER_H_

#include <cstdint>
#include <string>

#include "rt_core/excitation.h"
#include "rt_core/realtime.h"
#include "rt_core/safety.h"
#include "rt_core/status.h"
#include "rt_core/suspension_parameters.h"

namespace kcrig {

struct Interval {
  double lower = 0;
  double upper = 0;
};

// The experiment's defaults, in SI units (angles converted to rad on load).
struct ExperimentConfig {
  double phi = 0;             // excitation direction [rad]
  double z_a = 0;             // acting point height [m]
  double fmax = 0;            // ramp amplitude [N]
  double duration = 0;        // ramp time tf [s]
  double rate = 0;            // sample rate [Hz]
  double step = 0;            // integrator step [s]
  double sigma_position = 0;  // [m]
  double sigma_angle = 0;     // [rad]
  Interval phi_bounds;        // [rad]
  Interval z_a_bounds;        // [m]
};

struct KcrigConfig {
  std::string directory;
  SuspensionParameters<double> model;
  ExperimentConfig experiment;
};

// Reads model.yaml and experiment.yaml from `directory`; an empty
// `directory` means DefaultConfigDirectory().
Status LoadConfig(const std::string& directory, KcrigConfig* config);

// The software rig (config/plant.yaml): the config model with the "true"
// parameter values of the rig, its actuator, its own protection and its
// sensors. SI units.
struct PlantConfig {
  SuspensionParameters<double> model;
  bool noise = true;       // Gaussian sensor noise with the config sigmas
  std::uint64_t seed = 1;  // of the noise; each run adds its run number
  // Force-controlled hydraulic actuator: set-point -> load-cell force.
  double actuator_tau = 0.005;        // first-order lag [s]
  double actuator_dead_time = 0.002;  // [s]
  double actuator_force_max = 6000;   // the rig's own set-point clamp [N]
  double step = 1e-4;                 // true plant's integration step [s]
  int priority = 70;                  // emulator's SCHED_FIFO priority, 0 none
  // Own protection: beyond the travel, or no command for command_timeout
  // while enabled, the rig faults and ramps its force to zero.
  double travel_max = 0.03;                           // [m]
  double command_timeout = 0.05;                      // [s]
  double ramp_down_time = 0.2;                        // [s]
  Vec6<double> sensor_offset = Vec6<double>::Zero();  // [m, rad]
  double position_resolution = 1e-6;                  // quantization [m]
  double angle_resolution = 1e-6;                     // [rad]
  double load_cell_sigma = 0.5;                       // [N]
  double load_cell_resolution = 0.1;                  // [N]
};

// Reads `directory`/plant.yaml over `model` (true_parameters: NAME: VALUE
// overrides; sensors: noise, seed).
Status LoadPlantConfig(const std::string& directory,
                       const SuspensionParameters<double>& model,
                       PlantConfig* plant);

// The controller's settings (config/rig.yaml).
struct TimingBudget {
  double compute_p999_fraction = 0.2;  // of the period
  double wakeup_p99 = 5e-4;            // [s]
  double cycle_p999_fraction = 0.8;    // of the period
};

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

struct RigConfig {
  double period = 1e-3;  // [s]
  RealtimeOptions realtime;
  RunProfileTimes profile;
  SafetyLimits safety;
  TimingBudget budget;
  ModbusSettings modbus;
  CanSettings can;
};

Status LoadRigConfig(const std::string& directory, RigConfig* rig);

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
  // Input registers (rig -> controller).
  int status = 0, fault_code = 1, sample = 2, sequence_echo = 4, protocol = 5;
  int force[3] = {6, 8, 10};
  int y[6] = {12, 14, 16, 18, 20, 22};
  // One past the highest register used, per table.
  int holding_count() const;
  int input_count() const;
};

// Control word bits and the map's protocol version.
inline constexpr std::uint16_t kControlEnable = 1u << 0;
inline constexpr std::uint16_t kControlResetFault = 1u << 1;
inline constexpr std::uint16_t kModbusProtocolVersion = 1;

Status LoadModbusMap(const std::string& file, ModbusMap* map);

// Physical plausibility of a parameter set, also after --set overrides:
// finite values, positive mass/inertia/stiffness, non-negative damping, links
// longer than 1 mm. `source` prefixes the message (a file or "--set").
Status ValidateModel(const SuspensionParameters<double>& model,
                     const std::string& source);

// The config directory used when --config is not given: the installed one if
// present, else the source tree's.
std::string DefaultConfigDirectory();

// A short hex digest of the model's geometry, masses, spring and damping:
// every parameter but the bushing stiffnesses, which experiments estimate.
// Logs carry it so that logs recorded with different geometry configs are
// not mixed.
std::string GeometryFingerprint(const SuspensionParameters<double>& model);

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_CONFIG_LOADER_H_
