// Synthetic experiments made in-process the way `kcrig simulate` makes them:
// the model with "true" parameters, optional sensor noise, packed as a run
// log and prepared by the estimator's own MakeExperiment.
#ifndef KCRIG_TESTS_SUPPORT_SYNTHETIC_H_
#define KCRIG_TESTS_SUPPORT_SYNTHETIC_H_

#include <cstdint>

#include "estimator/experiment.h"
#include "gtest/gtest.h"
#include "io_drivers/config_loader.h"
#include "rt_core/measurement_noise.h"
#include "rt_core/simulation.h"

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
  log.metadata.phi = spec.phi;
  log.metadata.z_a = spec.z_a;
  log.metadata.fmax = spec.fmax;
  log.metadata.duration = spec.duration;
  log.metadata.sigma_position = config.experiment.sigma_position;
  log.metadata.sigma_angle = config.experiment.sigma_angle;
  MeasurementNoise noise(config.experiment.sigma_position,
                         config.experiment.sigma_angle, spec.seed);
  for (const TrajectorySample<double>& s : samples) {
    LogSample sample{s.t, s.force, s.y, Vec3<double>::Zero()};
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

// Truth values that differ per bushing, 3.6e6 .. 4.4e6 N/m.
inline SuspensionParameters<double> DistinctBushingTruth(
    const SuspensionParameters<double>& nominal) {
  SuspensionParameters<double> truth = nominal;
  const double values[kNumBushings] = {3.6e6, 4.4e6, 3.9e6, 4.25e6, 3.75e6};
  for (int i = 0; i < kNumBushings; ++i)
    truth.bushings[i].stiffness = values[i];
  return truth;
}

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_SYNTHETIC_H_
