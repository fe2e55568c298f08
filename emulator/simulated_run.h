// The pure model simulation: one ramp experiment on a plant model from its
// static equilibrium, sampled at the log rate, exact forces, optional sensor
// noise, as a run log: no loop, no phases, no actuator, no memory between
// runs. For design studies (`kcrig simulate`) and the validation's blind
// cases; the campaign's embedded rig is the SIL rig (sil_rig.h).
#ifndef KCRIG_EMULATOR_SIMULATED_RUN_H_
#define KCRIG_EMULATOR_SIMULATED_RUN_H_

#include <cstdint>
#include <string>

#include "emulator/plant_config.h"
#include "records/run_log.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/model_config.h"
#include "rt_core/model/plant_effects.h"

namespace kcrig {

struct SimulatedRunOptions {
  double rate = 1000;  // log rate [Hz]; 1/rate a multiple of the step
  // The plant's integration step [s]; 0: the model's (experiment.step). A
  // rig is continuous: the embedded rig steps finer than the model, as
  // `kcrig emulate` does (plant.yaml's rig.step).
  double step = 0;
  bool noise = false;                    // add the experiment's sensor noise
  std::uint64_t seed = 1;                // of the noise
  std::string transport = "simulation";  // recorded in the sidecar
  PlantEffects effects;                  // unmodelled effects of the plant
  // GeometryFingerprint of the configured model, recorded in the sidecar.
  std::string geometry;
};

// Simulates `plant` with options.effects (rt_core/model/rig_plant.h) under
// `ramp` (from the static equilibrium under its first load) and fills `log`:
// forces exact (the load cell's), channels as the sensors read them with noise
// when asked, sidecar metadata from `experiment` (sigmas, step) and the plant
// and its effects as truth.
Status SimulateRun(const SuspensionParameters<double>& plant,
                   const RampExcitation<double>& ramp,
                   const ExperimentConfig& experiment,
                   const SimulatedRunOptions& options, RunLog* log);

}  // namespace kcrig

#endif  // KCRIG_EMULATOR_SIMULATED_RUN_H_
