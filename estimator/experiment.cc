#include "estimator/experiment.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "estimator/internal/applied_force.h"
#include "records/read_log.h"
#include "rt_core/model/excitation.h"

namespace kcrig {
namespace {

// The rows of a rig log (one with a phase column) before its settle at
// -Fmax: see Experiment::observed.
int MemoryRows(const RunLog& log) {
  int rows = 0;
  for (const LogSample& s : log.samples) {
    if (s.phase != RunPhaseName(RunPhase::kTare) &&
        s.phase != RunPhaseName(RunPhase::kLeadIn)) {
      break;
    }
    ++rows;
  }
  return rows;
}

// A rig log's tare: the mean of its fresh tare rows, and per channel the
// straight line through them at the first row (a structure still relaxing
// from the last run moves during the tare; the line's slope takes that
// out). Unset without any fresh tare row.
std::optional<TarePose> TareOf(const RunLog& log) {
  const double t0 = log.samples.front().t;
  Vec6<double> sum_y = Vec6<double>::Zero(), sum_ty = Vec6<double>::Zero();
  double sum_t = 0, sum_tt = 0;
  int count = 0;
  for (const LogSample& s : log.samples) {
    if (s.phase != RunPhaseName(RunPhase::kTare)) break;
    if (!s.fresh) continue;
    const double t = s.t - t0;
    sum_y += s.y;
    sum_ty += t * s.y;
    sum_t += t;
    sum_tt += t * t;
    ++count;
  }
  if (count == 0) return std::nullopt;
  TarePose tare;
  tare.mean = sum_y / count;
  tare.at_start = tare.mean;
  const double t_mean = sum_t / count;
  const double spread = sum_tt - count * t_mean * t_mean;
  if (count >= 3 && spread > 0) {
    tare.at_start -= (sum_ty - t_mean * sum_y) / spread * t_mean;
  }
  return tare;
}

// The actuator's response to its command within 50 ms (dead time and lag);
// what is slower is left to the moving average.
int ActuatorResponseTaps(double rate) {
  return std::max(1, static_cast<int>(std::lround(0.05 * rate)));
}

// +-10 ms: the load cell's noise down by about 4.6 at 1 kHz; the force the
// response leaves varies slower than that.
int LoadCellSmoothing(double rate) {
  return std::max(0, static_cast<int>(std::lround(0.01 * rate)));
}

}  // namespace

Status MakeExperiment(const std::string& source, const RunLog& log,
                      double integrator_step, Experiment* experiment) {
  const RunMetadata& m = log.metadata;
  const double period = 1.0 / m.rate;
  const double t0 = log.samples.front().t;
  for (size_t j = 0; j < log.samples.size(); ++j) {
    const double expected = t0 + j * period;
    if (std::abs(log.samples[j].t - expected) > 0.01 * period) {
      return Status::Error(source + ":" + std::to_string(j + 2) +
                           ": sample times are not evenly spaced at " +
                           std::to_string(m.rate) + " Hz");
    }
  }
  const double ratio = period / integrator_step;
  const long steps = std::lround(ratio);
  if (steps < 1 || std::abs(ratio - steps) > 1e-9 * ratio) {
    return Status::Error(source + ": sample period " + std::to_string(period) +
                         " s is not a whole multiple of the integrator step " +
                         std::to_string(integrator_step) + " s");
  }
  experiment->source = source;
  experiment->sample_period = period;
  experiment->steps_per_sample = static_cast<int>(steps);
  experiment->z_a = m.excitation.z_a;
  experiment->measured_force = log.has_measured_force;
  experiment->geometry = m.geometry;
  experiment->sigma << Vec3<double>::Constant(m.sigma_position),
      Vec3<double>::Constant(m.sigma_angle);
  experiment->forces.clear();
  experiment->measured.clear();
  experiment->observed.clear();
  // The measured force when the rig has a load cell, else the commanded
  // set-points the rig log recorded, else the commanded ramp of the sidecar
  // (its time origin is the log's first sample).
  const RampExcitation<double>& commanded = m.excitation;
  std::vector<Vec3<double>> commanded_forces;  // the loop's, when logged
  for (const LogSample& s : log.samples) {
    if (log.has_commanded_force) commanded_forces.push_back(s.commanded);
    experiment->forces.push_back(log.has_measured_force ? s.force
                                 : log.has_commanded_force
                                     ? s.commanded
                                     : commanded.LoadAt(s.t - t0).force);
    experiment->measured.push_back(s.y);
  }
  const size_t n = log.samples.size();
  if (std::any_of(log.samples.begin(), log.samples.end(),
                  [](const LogSample& s) { return !s.fresh; })) {
    experiment->observed.resize(n);
    std::vector<size_t> fresh;
    for (size_t j = 0; j < n; ++j) {
      experiment->observed[j] = log.samples[j].fresh;
      if (log.samples[j].fresh) fresh.push_back(j);
    }
    if (fresh.size() < 2) {
      return Status::Error(source +
                           ": fewer than two rows with a fresh "
                           "measurement (column 'fresh')");
    }
    // The load between fresh samples, linear in time (the ramp is linear).
    size_t next = 0;
    for (size_t j = 0; j < n; ++j) {
      if (log.samples[j].fresh) continue;
      while (next < fresh.size() && fresh[next] < j) ++next;
      const size_t after = std::min(next, fresh.size() - 1);
      const size_t before = next > 0 ? fresh[next - 1] : fresh[0];
      const size_t right = fresh[after];
      const double w = right == before
                           ? 0.0
                           : static_cast<double>(j - before) /
                                 static_cast<double>(right - before);
      experiment->forces[j] =
          (1 - std::clamp(w, 0.0, 1.0)) * experiment->forces[before] +
          std::clamp(w, 0.0, 1.0) * experiment->forces[right];
    }
  }
  if (log.has_measured_force && log.has_commanded_force) {
    experiment->forces =
        AppliedForce(experiment->forces, commanded_forces,
                     ActuatorResponseTaps(m.rate), LoadCellSmoothing(m.rate));
  }
  experiment->memory_rows = MemoryRows(log);
  experiment->tare = TareOf(log);
  if (experiment->memory_rows > 0) {
    experiment->observed.resize(n, true);
    std::fill_n(experiment->observed.begin(), experiment->memory_rows, false);
    if (ObservedCount(*experiment) < 2) {
      return Status::Error(source +
                           ": fewer than two fresh rows after the tare and "
                           "the lead-in (the run ended before its settle at "
                           "-Fmax): nothing to fit that the rig's memory of "
                           "its last run leaves alone");
    }
  }
  return Status::Ok();
}

Status LoadExperiment(const std::string& path, const KcrigConfig& config,
                      const std::string& dbc_file, Experiment* experiment,
                      RunLog* log_out) {
  CanLogDecoderOptions can;
  can.dbc_file = dbc_file;
  can.sigma_position = config.experiment.sigma_position;
  can.sigma_angle = config.experiment.sigma_angle;
  RunLog log;
  KCRIG_RETURN_IF_ERROR(ReadLog(path, can, &log));
  KCRIG_RETURN_IF_ERROR(
      MakeExperiment(path, log, config.experiment.step, experiment));
  const std::string geometry = GeometryFingerprint(config.model);
  if (!experiment->geometry.empty() && experiment->geometry != geometry) {
    return Status::Error(
        path + ": recorded with geometry " + experiment->geometry + ", but " +
        config.directory + "/model.yaml is geometry " + geometry +
        ": a log from a different geometry config cannot be analysed with "
        "this model (use its --config)");
  }
  if (log_out != nullptr) *log_out = std::move(log);
  return Status::Ok();
}

Experiment PlannedExperiment(const RampExcitation<double>& ramp,
                             const ExperimentConfig& config) {
  Experiment e;
  e.source = "design";
  e.sample_period = 1.0 / config.rate;
  e.steps_per_sample =
      static_cast<int>(std::lround(e.sample_period / config.step));
  e.z_a = ramp.z_a;
  e.sigma << Vec3<double>::Constant(config.sigma_position),
      Vec3<double>::Constant(config.sigma_angle);
  const long intervals =
      std::lround(std::floor(ramp.EndTime() * config.rate + 1e-9));
  for (long j = 0; j <= intervals; ++j) {
    e.forces.push_back(ramp.LoadAt(j * e.sample_period).force);
  }
  e.measured.assign(e.forces.size(), Vec6<double>::Zero());
  return e;
}

Status LoadExperiments(const std::vector<std::string>& paths,
                       const KcrigConfig& config, const std::string& dbc_file,
                       std::vector<Experiment>* experiments) {
  experiments->assign(paths.size(), Experiment());
  for (size_t i = 0; i < paths.size(); ++i) {
    const Status status =
        LoadExperiment(paths[i], config, dbc_file, &(*experiments)[i]);
    if (!status.ok()) return status;
  }
  return Status::Ok();
}

std::vector<Experiment> RefinedExperiments(std::vector<Experiment> experiments,
                                           int factor) {
  for (Experiment& e : experiments) e.steps_per_sample *= factor;
  return experiments;
}

Status CheckSameForceChannels(const std::vector<Experiment>& training,
                              const std::vector<Experiment>& holdout) {
  if (training.empty()) return Status::Ok();
  const Experiment& first = training.front();
  for (const std::vector<Experiment>* set : {&training, &holdout}) {
    for (const Experiment& e : *set) {
      if (e.measured_force == first.measured_force) continue;
      const Experiment& with = e.measured_force ? e : first;
      const Experiment& without = e.measured_force ? first : e;
      return Status::Error(
          without.source + " has no load-cell force columns (Fx,Fy,Fz) but " +
          with.source +
          " has: logs with different channel sets cannot be used together");
    }
  }
  return Status::Ok();
}

}  // namespace kcrig
