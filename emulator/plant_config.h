// The software rig's configuration (config/plant.yaml).
#ifndef KCRIG_EMULATOR_PLANT_CONFIG_H_
#define KCRIG_EMULATOR_PLANT_CONFIG_H_

#include <cstdint>
#include <string>

#include "base/status.h"
#include "rt_core/model/plant_effects.h"
#include "rt_core/model/suspension_parameters.h"

namespace kcrig {

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
  int cpu = -1;  // CPU to pin the emulator to (rig.cpu, optional), -1 none
  // Own protection: beyond the travel, or no command for command_timeout
  // while enabled, the rig faults and ramps its force to zero.
  double travel_max = 0.03;       // [m]
  double command_timeout = 0.05;  // [s]
  // The owner's claim ends after this long without a request from it (or
  // when its connection closes); longer than command_timeout, so that a
  // transient stall faults the rig but leaves the claim with its owner.
  double claim_timeout = 1.0;   // [s]
  double ramp_down_time = 0.2;  // [s]
  // The embedded SIL rig's rest between one run's end and the next run's
  // start (a campaign estimates and designs meanwhile) [s]; its state
  // carries over whatever the rest.
  double rest_between_runs = 2.0;
  // Whether the embedded SIL rig's plant keeps its state from one run to
  // the next, as every rig does (false: each run starts from the plant at
  // rest, no friction force kept, as the pure simulation's runs do).
  bool keeps_state = true;
  Vec6<double> sensor_offset = Vec6<double>::Zero();  // [m, rad]
  double position_resolution = 1e-6;                  // quantization [m]
  double angle_resolution = 1e-6;                     // [rad]
  double load_cell_sigma = 0.5;                       // [N]
  double load_cell_resolution = 0.1;                  // [N]
  // Unmodelled effects of the true plant (plant.yaml's optional `effects`,
  // a list in the --effect syntax; kcrig emulate --effect and kcrig
  // campaign --plant-effect add to them).
  PlantEffects effects;
};

// Reads `directory`/plant.yaml over `model` (true_parameters: NAME: VALUE
// overrides; sensors: noise, seed; effects: ["NAME:k=v,...", ...]).
Status LoadPlantConfig(const std::string& directory,
                       const SuspensionParameters<double>& model,
                       PlantConfig* plant);

}  // namespace kcrig

#endif  // KCRIG_EMULATOR_PLANT_CONFIG_H_
