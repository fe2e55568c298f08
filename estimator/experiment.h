// One logged experiment, prepared for the model: the measured load (forces
// interpolated between samples, at the sidecar's acting height), the six
// measured channels and their sensor sigmas.
#ifndef KCRIG_ESTIMATOR_EXPERIMENT_H_
#define KCRIG_ESTIMATOR_EXPERIMENT_H_

#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "records/can_log_decoder.h"
#include "records/run_log.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/model_config.h"
#include "rt_core/model/rotation.h"
#include "rt_core/model/tare_pose.h"

namespace kcrig {

struct Experiment {
  std::string source;  // file name, for messages
  // Load on the wheel at t_j [N]. In a rig log with a load cell and the
  // loop's command, the force the rig applied: the load cell's reading with
  // its noise taken out (internal/applied_force.h says why and how).
  std::vector<Vec3<double>> forces;
  std::vector<Vec6<double>> measured;  // x, y, z [m], angles [rad] at t_j
  // Whether sample j enters the fit and its statistics. A rig log's row
  // with fresh = 0 carries no new measurement: its residual is zero and its
  // force is interpolated between the neighbouring fresh samples. A rig
  // log's tare and lead-in rows are measured but left out: they start from
  // the state the rig kept from its last run (a bushing's hysteresis, a
  // structure still relaxing), which no model knows; the lead-in to -Fmax
  // wipes most of that memory out, in the rig and in the model, which runs
  // through those rows (from rest, or from the state the tare shows:
  // `tare`). Empty: all samples enter.
  std::vector<bool> observed;
  // Of them, the leading rows left out as the rig's memory (tare, lead-in).
  int memory_rows = 0;
  // A rig log's tare, what the rig kept from its last run: its mean, and
  // the pose at the first row (a line through the fresh tare rows; their
  // mean below three rows). A
  // model with hysteresis starts from the Dahl forces that explain the
  // mean, one with bushing damping from the first row's pose
  // (BasicRigPlant::SettleAtRest). Unset for a log without phases.
  std::optional<TarePose> tare;
  double sample_period = 0;  // [s]
  double z_a = 0;            // acting height [m]
  Vec6<double> sigma = Vec6<double>::Ones();
  int steps_per_sample = 1;  // integrator steps per sample
  // Whether the forces are the load cell's (else the sidecar's commanded
  // excitation), and the log's GeometryFingerprint ("" when unrecorded):
  // logs that differ in either cannot be compared under one model.
  bool measured_force = true;
  std::string geometry;
};

// Whether sample j of `e` carries a measurement (see Experiment::observed).
inline bool Observed(const Experiment& e, size_t j) {
  return e.observed.empty() || e.observed[j];
}

// Per experiment, its leading rows left out as the rig's memory.
inline std::vector<int> MemoryRows(const std::vector<Experiment>& all) {
  std::vector<int> rows;
  for (const Experiment& e : all) rows.push_back(e.memory_rows);
  return rows;
}

// The number of samples of `e` that carry one.
inline int ObservedCount(const Experiment& e) {
  int n = 0;
  for (size_t j = 0; j < e.measured.size(); ++j) n += Observed(e, j);
  return n;
}

// Checks that the samples are evenly spaced at the sidecar's rate and that
// the sample period is a whole multiple of the integrator step; rows without
// a fresh sample become unobserved (see Experiment::observed).
Status MakeExperiment(const std::string& source, const RunLog& log,
                      double integrator_step, Experiment* experiment);

// A log read by records' ReadLog (a CAN bus log decoded with `dbc_file`
// and the config's sensor sigmas; "" refuses one), then MakeExperiment with
// the config's integrator step. A log recorded with another geometry than
// the config's model is refused: no model here can explain it.
// `log`, when not null, receives the log read (its phases and sidecar).
Status LoadExperiment(const std::string& path, const KcrigConfig& config,
                      const std::string& dbc_file, Experiment* experiment,
                      RunLog* log = nullptr);

// An experiment not yet run: the excitation's forces sampled at the
// config's log rate over the whole excitation, the config's integrator step
// and sensor sigmas, no measurements (zeros). What designs are evaluated on.
Experiment PlannedExperiment(const RampExcitation<double>& ramp,
                             const ExperimentConfig& config);

// `experiments` integrated `factor` times finer: the same samples with
// `factor` times the integrator steps per sample (a step of step / factor).
std::vector<Experiment> RefinedExperiments(std::vector<Experiment> experiments,
                                           int factor);

// Logs fitted, predicted or scored under one model must drive it with the
// same force channels (all the load cell's, or all the commanded
// excitation): an error naming two logs of `training` and `holdout` that
// differ.
Status CheckSameForceChannels(const std::vector<Experiment>& training,
                              const std::vector<Experiment>& holdout);

// LoadExperiment for each path, in order.
Status LoadExperiments(const std::vector<std::string>& paths,
                       const KcrigConfig& config, const std::string& dbc_file,
                       std::vector<Experiment>* experiments);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_EXPERIMENT_H_
