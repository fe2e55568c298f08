// The model's configuration: config/model.yaml (geometry, masses, bushings,
// spring) and config/experiment.yaml (excitation defaults, integrator step,
// sensor sigmas, design bounds), in SI units. Every error is one line naming
// the file, the line and the key.
#ifndef KCRIG_RT_CORE_MODEL_MODEL_CONFIG_H_
#define KCRIG_RT_CORE_MODEL_MODEL_CONFIG_H_

#include <string>

#include "base/status.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/suspension_parameters.h"

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

  // The paper's ramp in direction `phi` [rad] at height `z_a` [m] with this
  // experiment's Fmax and tf: what a design (phi, z_a) runs.
  RampExcitation<double> Excitation(double phi, double z_a) const {
    return {phi, z_a, fmax, duration};
  }
};

struct KcrigConfig {
  std::string directory;
  SuspensionParameters<double> model;
  ExperimentConfig experiment;
};

// Reads model.yaml and experiment.yaml from `directory`; an empty
// `directory` means DefaultConfigDirectory().
Status LoadConfig(const std::string& directory, KcrigConfig* config);

// Physical plausibility of a parameter set, also after --set overrides:
// finite values, positive mass/inertia/stiffness, non-negative damping, links
// longer than 1 mm. `source` prefixes the message (a file or "--set").
Status ValidateModel(const SuspensionParameters<double>& model,
                     const std::string& source);

// The config directory used when --config is not given: the one installed
// beside the running binary (its bin/../share/kcrig/config); for a binary
// in its build tree without one, the source tree's.
std::string DefaultConfigDirectory();

// A short hex digest of the model's geometry, masses, spring and damping:
// every parameter but the bushing stiffnesses, which experiments estimate.
// Logs carry it so that logs recorded with different geometry configs are
// not mixed.
std::string GeometryFingerprint(const SuspensionParameters<double>& model);

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_MODEL_CONFIG_H_
