// Synthetic experiments made in-process the way `kcrig simulate` makes them:
// the model with "true" parameters, optional sensor noise, packed as a run
// log and prepared by the estimator's own MakeExperiment.
#ifndef KCRIG_TESTS_SUPPORT_SYNTHETIC_H_
#define KCRIG_TESTS_SUPPORT_SYNTHETIC_H_

#include <cmath>
#include <cstdint>

#include "emulator/simulated_run.h"
#include "estimator/experiment.h"
#include "gtest/gtest.h"
#include "rt_core/model/measurement_noise.h"
#include "rt_core/model/model_config.h"
#include "rt_core/model/simulation.h"

namespace kcrig {

struct SyntheticSpec {
  double phi;       // [rad]
  double z_a;       // [m]
  double fmax;      // [N]
  double duration;  // [s]
  bool noise = false;
  std::uint64_t seed = 1;
};

inline RunLog SyntheticLog(const KcrigConfig& config,
                           const SuspensionParameters<double>& truth,
                           const SyntheticSpec& spec) {
  const RampExcitation<double> ramp{spec.phi, spec.z_a, spec.fmax,
                                    spec.duration};
  SimulationOptions options;
  options.step = config.experiment.step;
  std::vector<TrajectorySample<double>> samples;
  const Status status = SimulateTrajectory(SuspensionModel<double>(truth), ramp,
                                           options, &samples);
  EXPECT_TRUE(status.ok()) << status.message();
  RunLog log;
  log.metadata.rate = 1.0 / config.experiment.step;
  log.metadata.excitation = ramp;
  log.metadata.sigma_position = config.experiment.sigma_position;
  log.metadata.sigma_angle = config.experiment.sigma_angle;
  MeasurementNoise noise(config.experiment.sigma_position,
                         config.experiment.sigma_angle, spec.seed);
  for (const TrajectorySample<double>& s : samples) {
    LogSample sample;
    sample.t = s.t;
    sample.force = s.force;
    sample.y = s.y;
    if (spec.noise) noise.Apply(&sample.y);
    log.samples.push_back(sample);
  }
  return log;
}

inline Experiment SyntheticExperiment(const KcrigConfig& config,
                                      const SuspensionParameters<double>& truth,
                                      const SyntheticSpec& spec) {
  Experiment experiment;
  const Status status =
      MakeExperiment("synthetic", SyntheticLog(config, truth, spec),
                     config.experiment.step, &experiment);
  EXPECT_TRUE(status.ok()) << status.message();
  return experiment;
}

// An experiment of the software rig's plant (`kcrig simulate`'s
// SimulateRun: `plant` with the unmodelled `effects`) under `ramp`, with
// sensor noise from `seed`. Needs kcrig_emulator.
inline Experiment PlantExperiment(const KcrigConfig& config,
                                  const SuspensionParameters<double>& plant,
                                  const PlantEffects& effects,
                                  const RampExcitation<double>& ramp,
                                  std::uint64_t seed) {
  SimulatedRunOptions options;
  options.noise = true;
  options.seed = seed;
  options.effects = effects;
  RunLog log;
  Status status = SimulateRun(plant, ramp, config.experiment, options, &log);
  EXPECT_TRUE(status.ok()) << status.message();
  Experiment experiment;
  status = MakeExperiment("plant", log, config.experiment.step, &experiment);
  EXPECT_TRUE(status.ok()) << status.message();
  return experiment;
}

// The same with the effect given as `--effect` text ("" for none).
inline Experiment PlantExperiment(const KcrigConfig& config,
                                  const SuspensionParameters<double>& plant,
                                  const std::string& effect,
                                  const RampExcitation<double>& ramp,
                                  std::uint64_t seed) {
  PlantEffects effects;
  if (!effect.empty()) {
    EXPECT_TRUE(ParseEffect(effect, &effects).ok()) << effect;
  }
  return PlantExperiment(config, plant, effects, ramp, seed);
}

// Truth values that differ per bushing, 3.6e6 .. 4.4e6 N/m.
inline SuspensionParameters<double> DistinctBushingTruth(
    const SuspensionParameters<double>& nominal) {
  SuspensionParameters<double> truth = nominal;
  const double values[kNumBushings] = {3.6e6, 4.4e6, 3.9e6, 4.25e6, 3.75e6};
  for (int i = 0; i < kNumBushings; ++i)
    truth.bushings[i].stiffness = values[i];
  return truth;
}

// The horizontal force direction (at the config's acting height) under which
// `link` carries no load. The five links and the spring form a statically
// determinate mount, so element forces follow from equilibrium alone, for
// any stiffness values, and are linear in the force: zero for one phi.
inline double DirectionUnloadingLink(const KcrigConfig& config, int link) {
  const SuspensionModel<double> model(config.model);
  double force_per_axis[2];
  for (int axis = 0; axis < 2; ++axis) {
    RigLoad<double> load;
    load.force = Vec3<double>::Zero();
    load.force(axis) = 1000.0;
    load.point << 0, 0, config.experiment.z_a;
    Vec6<double> y;
    EXPECT_TRUE(SolveStaticEquilibrium(model, load, 50, &y).ok());
    force_per_axis[axis] = model.ElementForces(y, Vec6<double>::Zero())(link);
  }
  return std::atan2(-force_per_axis[0], force_per_axis[1]);
}

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_SYNTHETIC_H_
