#include "emulator/simulated_run.h"

#include <cmath>
#include <vector>

#include "rt_core/measurement_noise.h"
#include "rt_core/simulation.h"

namespace kcrig {

Status SimulateRun(const SuspensionParameters<double>& plant,
                   const RampExcitation<double>& ramp,
                   const ExperimentConfig& experiment,
                   const SimulatedRunOptions& options, RunLog* log) {
  SimulationOptions simulation;
  simulation.step = experiment.step;
  const double ratio = 1.0 / (options.rate * experiment.step);
  simulation.steps_per_sample = static_cast<int>(std::lround(ratio));
  if (!(options.rate > 0) || simulation.steps_per_sample < 1 ||
      std::abs(ratio - simulation.steps_per_sample) > 1e-9 * ratio) {
    return Status::Error(
        "--rate " + std::to_string(options.rate) +
        ": the sample period must be a whole multiple of the integrator step " +
        std::to_string(experiment.step) + " s (integrator.step)");
  }
  std::vector<TrajectorySample<double>> trajectory;
  const Status status = SimulateTrajectory(SuspensionModel<double>(plant), ramp,
                                           simulation, &trajectory);
  if (!status.ok()) return status;

  *log = RunLog();
  RunMetadata& m = log->metadata;
  m.rate = options.rate;
  m.phi = ramp.phi;
  m.z_a = ramp.z_a;
  m.fmax = ramp.fmax;
  m.duration = ramp.duration;
  m.sigma_position = experiment.sigma_position;
  m.sigma_angle = experiment.sigma_angle;
  m.transport = options.transport;
  m.noise_added = options.noise;
  m.seed = options.seed;
  m.synthetic = true;
  SuspensionParameters<double> copy = plant;
  for (const NamedParameter<double>& p : ListParameters(&copy)) {
    m.truth_parameters.emplace_back(p.name, *p.value);
  }
  MeasurementNoise noise(m.sigma_position, m.sigma_angle, options.seed);
  log->samples.reserve(trajectory.size());
  for (const TrajectorySample<double>& s : trajectory) {
    LogSample sample{s.t, s.force, s.y, Vec3<double>::Zero()};
    if (options.noise) noise.Apply(&sample.y);
    log->samples.push_back(sample);
  }
  return Status::Ok();
}

Status RunEmbeddedRig(const KcrigConfig& config, const PlantConfig& plant,
                      double phi, double z_a, int run,
                      const std::string& csv_path) {
  const RampExcitation<double> ramp{phi, z_a, config.experiment.fmax,
                                    config.experiment.duration};
  SimulatedRunOptions options;
  options.rate = config.experiment.rate;
  options.noise = plant.noise;
  options.seed = plant.seed + static_cast<std::uint64_t>(run);
  options.transport = "embedded emulated rig (--rig sim)";
  RunLog log;
  const Status status =
      SimulateRun(plant.model, ramp, config.experiment, options, &log);
  if (!status.ok()) return status;
  return WriteRunLog(csv_path, log);
}

}  // namespace kcrig
