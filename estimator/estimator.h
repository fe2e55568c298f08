// Weighted nonlinear least squares for the suspension parameters (paper
// eq. 6), solved with Ceres' Levenberg-Marquardt on exact discrete
// sensitivities, with the linearized uncertainty and an identifiability
// analysis of the Jacobian at the solution.
#ifndef KCRIG_ESTIMATOR_ESTIMATOR_H_
#define KCRIG_ESTIMATOR_ESTIMATOR_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "base/iteration_callback.h"
#include "base/parallel_for.h"
#include "base/status.h"
#include "estimator/adequacy.h"
#include "estimator/experiment.h"
#include "rt_core/model/channels.h"
#include "rt_core/model/suspension_parameters.h"

namespace kcrig {

struct EstimatorOptions {
  // Parameters to estimate, by name (see ListParameters); the others keep
  // their config values. Default: the five bushing stiffnesses.
  std::vector<std::string> parameters = {"c_O1", "c_O2", "c_V1", "c_V2", "c_P"};
  // Channels in the residual, indices into x, y, z, toe, camber, caster.
  std::vector<int> channels = {0, 1, 2, 3, 4, 5};
  // Box on the scaled parameters p / p_nominal.
  double lower_scale = 0.1;
  double upper_scale = 10.0;
  // Levenberg-Marquardt limits. The relative cost change of 1e-10 moves a
  // noisy fit by ~1e-5 standard errors, and noise-free synthetic data still
  // come back to ~1e-15 (quadratic convergence at zero residual).
  int max_iterations = 100;
  double function_tolerance = 1e-10;
  double gradient_tolerance = 1e-16;
  double parameter_tolerance = 1e-12;
  // Residual blocks (experiments) are evaluated on this many threads.
  int num_threads = kDefaultThreads;
  // A direction of parameter space whose singular value is below this
  // fraction of the largest is not determined by the data at all (numerical
  // rank); its parameters get no standard errors.
  double rank_tolerance = 1e-8;
  // A direction whose standard error at the stated sensor sigmas, 1 / s_i
  // in scaled parameters, exceeds this fraction of the nominal values is
  // practically not identifiable: its 95 % interval would be wider than
  // +-20 % of nominal, useless for a bushing rate.
  double max_relative_standard_error = 0.1;
  // Condition numbers above this are reported as ill-conditioned.
  double ill_conditioned_above = 1e6;
  // The tests of the fit's adequacy (and of a prediction's).
  AdequacyOptions adequacy;
  // A fit that would need more heap than this is refused up front, with one
  // line saying how much it needs (FitMemoryBytes), instead of being killed
  // half-way. 0: the memory available when the fit starts
  // (AvailableMemoryBytes).
  std::uint64_t memory_budget_bytes = 0;
  // Asked after every Levenberg-Marquardt iteration of Estimate and after
  // every point of a profile likelihood; kAbort stops them with
  // Interrupted(). Optional.
  IterationCallback callback;
};

// The two-sided 95 % quantile of the normal distribution: a 95 % interval
// is the value +- kZ95 standard errors.
inline constexpr double kZ95 = 1.959963984540054;

struct ParameterEstimate {
  std::string name;
  std::string unit;
  double nominal = 0;         // config value, the scale [unit]
  double initial = 0;         // start of the fit [unit]
  double value = 0;           // estimate [unit]
  double standard_error = 0;  // [unit]; infinite when not identifiable
  double ci95_low = 0, ci95_high = 0;
  // log10 of the diagonal of (J^T J)^-1 in scaled parameters (paper Fig. 4).
  double log10_inverse_information = 0;
  bool identifiable = true;
  // The estimate sits on its bound (LeastSquaresProblem::AtBound).
  bool at_bound = false;
  // [unit] the first-order bias the model's discretisation error leaves in
  // the value (AddDiscretisationBias); 0 where not estimated.
  double discretisation_bias = 0;
};

// A log's initial state: where its model started, what the rig kept from
// its last run (docs/rig.md, "How kcrig handles the memory").
struct LogInitialState {
  // The log's tare (Experiment::tare). A log without phases has none.
  std::optional<TarePose> tare;
  // A model with bushing damping started at the tare's first-row pose (a
  // structure still creeping).
  bool from_first_row_pose = false;
  // [N] per bushing, O1..P (0 where none; NaN where the settle failed): a
  // model with hysteresis started from these Dahl forces, which put its
  // sensors at the tare's mean (with bushing damping too, they hold the
  // equilibrium the structure creeps to from the first row's pose). Empty
  // without hysteresis or without a tare. Without Dahl forces and not from
  // the first row's pose, the model started at rest under the first force.
  std::vector<double> dahl_forces;
};

// Per experiment, the initial state of a model that starts at rest under
// the first force (no Dahl forces, not from the first row's pose).
std::vector<LogInitialState> InitialStatesAtEquilibrium(
    const std::vector<Experiment>& experiments);

struct EstimationResult {
  std::vector<ParameterEstimate> parameters;
  Eigen::MatrixXd covariance;  // sigma_hat^2 (J^T J)^-1, physical units
  Eigen::MatrixXd correlation;
  Eigen::VectorXd singular_values;  // of the weighted J, scaled parameters
  // J^T J of the weighted J in scaled parameters: the information of the
  // data (paper eq. 9), the prior of a sequential design.
  Eigen::MatrixXd information;
  double condition_number = 0;
  int rank = 0;
  bool ill_conditioned = false;
  // Directions of parameter space the data cannot resolve, as text like
  // "0.707 c_V1 - 0.707 c_V2 (...why...)" (from the SVD), and the parameters
  // pivoted QR puts beyond the numerical rank.
  std::vector<std::string> unidentifiable_combinations;
  std::vector<std::string> dependent_parameters;
  Vec6<double> residual_rms = Vec6<double>::Zero();  // per channel, SI units
  std::vector<bool> channel_used = std::vector<bool>(6, false);
  int num_residuals = 0;
  // Per log, its leading rows left out as the rig's memory of its last run
  // (tare and lead-in; Experiment::memory_rows).
  std::vector<int> memory_rows;
  // Per log, the state its model started from (LogInitialState).
  std::vector<LogInitialState> initial_states;
  double cost = 0;       // 0.5 * sum of squared weighted residuals
  double sigma_hat = 0;  // sqrt(2 cost / (m - n)); ~1 when sigmas are right
  // The residual's correlation (ResidualStructure::correlation: 1 for white
  // noise) and by how much the widest interval was widened for it
  // (WidenForResidualStructure; 1: the classical intervals hold).
  double residual_correlation = 1;
  double interval_widening = 1;
  // Whether the model explains the fitted logs down to the sensor noise.
  // When not, the intervals (which assume a correct model) are not to be
  // trusted.
  Adequacy adequacy;
  int iterations = 0;
  double seconds = 0;
  // [s] the step the model was integrated at (0: not recorded): an
  // estimate's model is the model at this step (est.json integrator_step_s).
  double integrator_step = 0;
  bool converged = false;
  std::string termination;
};

// Fits options.parameters to all `experiments` jointly, starting from
// `initial` (physical values, one per parameter).
Status Estimate(const SuspensionParameters<double>& nominal,
                const std::vector<Experiment>& experiments,
                const EstimatorOptions& options,
                const std::vector<double>& initial, double integrator_step,
                EstimationResult* result);

// Predicts `experiments`, which the fit `result` has not seen, with its
// parameter values: the prediction's adequacy against the sensor noise
// (score per channel, chi-square tail, whiteness). Same options and
// integrator step as the fit.
Status PredictExperiments(const SuspensionParameters<double>& nominal,
                          const std::vector<Experiment>& experiments,
                          const EstimatorOptions& options,
                          const EstimationResult& result,
                          double integrator_step, Adequacy* prediction);

// The uncertainty and identifiability part of Estimate, for a weighted
// Jacobian (scaled parameters) at a solution: fills singular values, rank,
// condition, unidentifiable combinations, dependent parameters, covariance,
// correlation and each parameter's standard error, interval and
// log10 diag((J^T J)^-1). Needs result->parameters (names, nominal, value)
// and result->sigma_hat. Takes J by value and factors it in place: move a
// long log's J in.
void AnalyzeUncertainty(Eigen::MatrixXd jacobian,
                        const EstimatorOptions& options,
                        EstimationResult* result);

// The parameters' first-order bias from the model's discretisation error
// e (weighted residuals, Richardson's estimate): a fit at step h minimises
// |r_0 + e| instead of the continuous-time |r_0|, so theta_h - theta_0 =
// -(J^T J)^+ J^T e. Records it per parameter and widens each interval by
// its size: the standard errors shrink with every sample while a bias of a
// fraction of the noise per sample does not, and an interval must cover
// the continuous-time value, which is the rig's. `gradient`: J^T e with
// AnalyzeUncertainty's J, after which it is called (it needs the
// information and the intervals).
void AddDiscretisationBias(const Eigen::VectorXd& gradient,
                           EstimationResult* result);

// Indices into ListParameters() of `names`, checking that they exist, are
// distinct, number at most kMaxEstimatedParameters and have non-zero
// nominal values.
Status ResolveParameters(const SuspensionParameters<double>& nominal,
                         const std::vector<std::string>& names,
                         std::vector<int>* indices);

// The values in `model` of the parameters at `indices` (ResolveParameters).
std::vector<double> ParameterValues(const SuspensionParameters<double>& model,
                                    const std::vector<int>& indices);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_ESTIMATOR_H_
