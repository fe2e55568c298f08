#include "emulator/simulated_run.h"

#include <cmath>
#include <vector>

#include "rt_core/model/measurement_noise.h"
#include "rt_core/model/rig_plant.h"
#include "rt_core/model/simulation.h"

namespace kcrig {

Status SimulateRun(const SuspensionParameters<double>& plant,
                   const RampExcitation<double>& ramp,
                   const ExperimentConfig& experiment,
                   const SimulatedRunOptions& options, RunLog* log) {
  SimulationOptions simulation;
  simulation.step = options.step > 0 ? options.step : experiment.step;
  const double ratio = 1.0 / (options.rate * simulation.step);
  simulation.steps_per_sample = static_cast<int>(std::lround(ratio));
  if (!(options.rate > 0) || simulation.steps_per_sample < 1 ||
      std::abs(ratio - simulation.steps_per_sample) > 1e-9 * ratio) {
    return Status::Error(
        "--rate " + std::to_string(options.rate) +
        ": the sample period must be a whole multiple of the plant's "
        "integration step " +
        std::to_string(simulation.step) + " s");
  }
  const long num_samples =
      std::lround(std::floor(ramp.EndTime() * options.rate + 1e-9)) + 1;
  RigPlant rig(plant, options.effects, simulation.step);
  const Status settled = rig.Settle(ramp.LoadAt(0.0).force, ramp.z_a);
  if (!settled.ok()) return settled;
  *log = RunLog();
  RunMetadata& m = log->metadata;
  m.rate = options.rate;
  m.excitation = ramp;
  m.sigma_position = experiment.sigma_position;
  m.sigma_angle = experiment.sigma_angle;
  m.transport = options.transport;
  m.geometry = options.geometry;
  m.noise_added = options.noise;
  m.seed = options.seed;
  m.synthetic = true;
  SuspensionParameters<double> copy = plant;
  for (const NamedParameter<double>& p : ListParameters(&copy)) {
    m.truth_parameters.emplace_back(p.name, *p.value);
  }
  m.truth_effects = DescribeEffects(options.effects);
  MeasurementNoise noise(m.sigma_position, m.sigma_angle, options.seed);
  log->samples.reserve(num_samples);
  long step_index = 0;
  for (long j = 0; j < num_samples; ++j) {
    for (int s = 0; j > 0 && s < simulation.steps_per_sample; ++s) {
      rig.Step(ramp.LoadAt(++step_index * simulation.step).force);
    }
    const double t = step_index * simulation.step;
    if (!rig.Finite(simulation.divergence_limit)) {
      return Status::Error("simulation diverged at t = " + std::to_string(t) +
                           " s (state beyond the model's range)");
    }
    LogSample sample;
    sample.t = t;
    sample.force = ramp.LoadAt(t).force;
    sample.y = rig.Sensed();
    if (options.noise) noise.Apply(&sample.y);
    log->samples.push_back(sample);
  }
  return Status::Ok();
}

}  // namespace kcrig
