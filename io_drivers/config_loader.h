// Loads and validates kcrig's YAML configuration (config/model.yaml and
// config/experiment.yaml). Every error is one line naming the file, the line
// and the key, e.g. "config/model.yaml:14: bushings.O1.stiffness: must be > 0".
#ifndef KCRIG_IO_DRIVERS_CONFIG_LOADER_H_
#define KCRIG_IO_DRIVERS_CONFIG_LOADER_H_

#include <cstdint>
#include <string>

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

// The software rig's true plant (config/plant.yaml): the config model with
// the "true" parameter values of the rig, and its sensors.
struct PlantConfig {
  SuspensionParameters<double> model;
  bool noise = true;       // Gaussian sensor noise with the config sigmas
  std::uint64_t seed = 1;  // of the noise; each run adds its run number
};

// Reads `directory`/plant.yaml over `model` (true_parameters: NAME: VALUE
// overrides; sensors: noise, seed).
Status LoadPlantConfig(const std::string& directory,
                       const SuspensionParameters<double>& model,
                       PlantConfig* plant);

// Physical plausibility of a parameter set, also after --set overrides:
// finite values, positive mass/inertia/stiffness, non-negative damping, links
// longer than 1 mm. `source` prefixes the message (a file or "--set").
Status ValidateModel(const SuspensionParameters<double>& model,
                     const std::string& source);

// The config directory used when --config is not given: the installed one if
// present, else the source tree's.
std::string DefaultConfigDirectory();

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_CONFIG_LOADER_H_
