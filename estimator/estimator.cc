#include "estimator/estimator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <sstream>
#include <utility>

#include "Eigen/QR"
#include "Eigen/SVD"
#include "estimator/internal/fit_problem.h"
#include "estimator/residual_structure.h"
#include "estimator/trajectory_residual.h"

namespace kcrig {
namespace {

std::string Combination(const Eigen::VectorXd& direction,
                        const std::vector<ParameterEstimate>& parameters) {
  std::ostringstream text;
  text.precision(3);
  bool first = true;
  for (int i = 0; i < direction.size(); ++i) {
    if (std::abs(direction(i)) < 0.05) continue;
    const double c = direction(i);
    text << (first ? (c < 0 ? "-" : "") : (c < 0 ? " - " : " + "))
         << std::abs(c) << " " << parameters[i].name;
    first = false;
  }
  return text.str();
}

// The model's own discretisation error at `scaled`, in weighted residual
// units: Richardson's estimate 2 (y_h - y_h/2) for the first-order scheme,
// from the same problem on the same logs at half the integrator step (two
// trajectories per log, no sensitivities).
Status DiscretisationError(const SuspensionParameters<double>& nominal,
                           std::vector<Experiment> experiments,
                           const EstimatorOptions& options,
                           double integrator_step,
                           const std::vector<int>& indices,
                           const std::vector<double>& scaled,
                           const Eigen::VectorXd& residuals,
                           Eigen::VectorXd* error) {
  // The problem holds the experiments by reference: they outlive it here.
  const std::vector<Experiment> finer_experiments =
      RefinedExperiments(std::move(experiments), 2);
  FitProblem half(nominal, finer_experiments, options, 0.5 * integrator_step,
                  indices);
  Eigen::VectorXd finer;
  if (!half.Evaluate(scaled, nullptr, &finer, nullptr)) {
    return Status::Error("the model cannot be evaluated at half its step");
  }
  *error = 2.0 * (residuals - finer);
  return Status::Ok();
}

// BetterOfStepAndLimit with `assess` applied to the residual vector at the
// step and less its discretisation error.
template <typename Assess>
Adequacy AssessStepAndLimit(const std::vector<Experiment>& experiments,
                            const std::vector<int>& channels,
                            const Eigen::VectorXd& residuals,
                            const Eigen::VectorXd& discretisation,
                            Assess assess) {
  return BetterOfStepAndLimit(
      assess(residuals), assess(residuals - discretisation), experiments,
      SplitResiduals(experiments, channels, discretisation));
}

}  // namespace

std::vector<double> ParameterValues(const SuspensionParameters<double>& model,
                                    const std::vector<int>& indices) {
  SuspensionParameters<double> copy = model;
  const std::vector<NamedParameter<double>> list = ListParameters(&copy);
  std::vector<double> values;
  for (int index : indices) values.push_back(*list[index].value);
  return values;
}

Status ResolveParameters(const SuspensionParameters<double>& nominal,
                         const std::vector<std::string>& names,
                         std::vector<int>* indices) {
  if (names.empty()) return Status::Error("no parameters to estimate");
  if (names.size() > kMaxEstimatedParameters) {
    return Status::Error("at most " + std::to_string(kMaxEstimatedParameters) +
                         " parameters can be estimated at once");
  }
  SuspensionParameters<double> copy = nominal;
  const std::vector<NamedParameter<double>> list = ListParameters(&copy);
  indices->clear();
  for (const std::string& name : names) {
    int found = -1;
    for (size_t i = 0; i < list.size(); ++i) {
      if (list[i].name == name) found = static_cast<int>(i);
    }
    if (found < 0) return Status::Error("unknown parameter '" + name + "'");
    for (int previous : *indices) {
      if (previous == found) {
        return Status::Error("parameter '" + name + "' given twice");
      }
    }
    if (*list[found].value == 0) {
      return Status::Error("parameter '" + name +
                           "' has nominal value 0 and cannot be scaled");
    }
    indices->push_back(found);
  }
  return Status::Ok();
}

void AnalyzeUncertainty(Eigen::MatrixXd jacobian,
                        const EstimatorOptions& options,
                        EstimationResult* result) {
  const int n = static_cast<int>(jacobian.cols());
  // Identifiability: SVD of J through its R factor (J = QR, sigma(J) =
  // sigma(R)), and pivoted QR for which parameters fall beyond the rank.
  // J is factored in place (a long log's J is not copied); column pivoting
  // sees only inner products of columns, J^T J = R^T R, so R's pivoted QR
  // ranks the parameters as J's would.
  const Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(jacobian);
  const Eigen::MatrixXd r_factor =
      qr.matrixQR().topRows(n).triangularView<Eigen::Upper>();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(r_factor, Eigen::ComputeFullV);
  result->singular_values = svd.singularValues();
  result->information = r_factor.transpose() * r_factor;
  const double largest = svd.singularValues()(0);
  const double smallest = svd.singularValues()(n - 1);
  result->condition_number = smallest > 0
                                 ? largest / smallest
                                 : std::numeric_limits<double>::infinity();
  result->ill_conditioned =
      result->condition_number > options.ill_conditioned_above;
  result->rank = 0;
  Eigen::VectorXd null_involvement = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd weak_involvement = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < n; ++i) {
    const double s = svd.singularValues()(i);
    const Eigen::VectorXd direction = svd.matrixV().col(i);
    if (s <= options.rank_tolerance * largest) {
      result->unidentifiable_combinations.push_back(
          Combination(direction, result->parameters) +
          " (not determined by these data)");
      null_involvement = null_involvement.cwiseMax(direction.cwiseAbs());
      continue;
    }
    ++result->rank;
    if (1.0 / s > options.max_relative_standard_error) {
      char why[96];
      std::snprintf(why, sizeof(why),
                    " (standard error %.0f %% of nominal at the stated sensor "
                    "noise)",
                    100.0 / s);
      result->unidentifiable_combinations.push_back(
          Combination(direction, result->parameters) + why);
      weak_involvement = weak_involvement.cwiseMax(direction.cwiseAbs());
    }
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> pivoted(r_factor);
  pivoted.setThreshold(options.rank_tolerance);
  for (int i = pivoted.rank(); i < n; ++i) {
    result->dependent_parameters.push_back(
        result->parameters[pivoted.colsPermutation().indices()(i)].name);
  }

  // Covariance sigma_hat^2 (J^T J)^-1 = sigma_hat^2 V S^-2 V^T on the
  // identifiable subspace; parameters touching a null direction get no
  // numbers at all rather than huge ones.
  Eigen::MatrixXd inverse_information = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < result->rank; ++i) {
    const Eigen::VectorXd v = svd.matrixV().col(i);
    inverse_information +=
        v * v.transpose() / (svd.singularValues()(i) * svd.singularValues()(i));
  }
  Eigen::VectorXd scale(n);
  for (int i = 0; i < n; ++i) scale(i) = result->parameters[i].nominal;
  result->covariance = result->sigma_hat * result->sigma_hat *
                       scale.asDiagonal() * inverse_information *
                       scale.asDiagonal();
  result->correlation = Eigen::MatrixXd::Zero(n, n);
  const double inf = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) {
    ParameterEstimate& p = result->parameters[i];
    const bool determined = null_involvement(i) < 0.05;
    p.identifiable = determined && weak_involvement(i) < 0.05;
    const double variance = result->covariance(i, i);
    p.standard_error = determined ? std::sqrt(variance) : inf;
    p.ci95_low = p.value - kZ95 * p.standard_error;
    p.ci95_high = p.value + kZ95 * p.standard_error;
    p.log10_inverse_information =
        determined ? std::log10(inverse_information(i, i)) : inf;
  }
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < n; ++k) {
      const double d =
          std::sqrt(result->covariance(i, i) * result->covariance(k, k));
      result->correlation(i, k) =
          (std::isfinite(result->parameters[i].standard_error) &&
           std::isfinite(result->parameters[k].standard_error) && d > 0)
              ? result->covariance(i, k) / d
              : (i == k ? 1.0 : 0.0);
    }
  }
}

void AddDiscretisationBias(const Eigen::VectorXd& gradient,
                           EstimationResult* result) {
  // The information's pseudo-inverse: a direction the data do not
  // determine has no interval to widen.
  const Eigen::VectorXd bias =
      -result->information.completeOrthogonalDecomposition().solve(gradient);
  for (int i = 0; i < bias.size(); ++i) {
    ParameterEstimate& p = result->parameters[i];
    p.discretisation_bias = bias(i) * p.nominal;
    if (!std::isfinite(p.standard_error)) continue;
    const double half =
        kZ95 * p.standard_error + std::abs(p.discretisation_bias);
    p.ci95_low = p.value - half;
    p.ci95_high = p.value + half;
  }
}

std::vector<LogInitialState> InitialStatesAtEquilibrium(
    const std::vector<Experiment>& experiments) {
  std::vector<LogInitialState> states(experiments.size());
  for (size_t k = 0; k < experiments.size(); ++k) {
    states[k].tare = experiments[k].tare;
  }
  return states;
}

namespace {

// Preprocess: the parameters named and checked, each with its start scaled
// by its nominal value (within the box).
Status PreprocessEstimate(const SuspensionParameters<double>& nominal,
                          const std::vector<Experiment>& experiments,
                          const EstimatorOptions& options,
                          const std::vector<double>& initial,
                          std::vector<int>* indices,
                          std::vector<double>* scaled,
                          EstimationResult* result) {
  KCRIG_RETURN_IF_ERROR(
      ResolveParameters(nominal, options.parameters, indices));
  if (experiments.empty()) return Status::Error("no experiments to fit");
  if (options.channels.empty()) return Status::Error("no channels selected");
  if (initial.size() != indices->size()) {
    return Status::Error("one initial value per parameter is needed");
  }
  if (!(options.lower_scale > 0 && options.lower_scale < 1.0 &&
        options.upper_scale > 1.0)) {
    return Status::Error("scale bounds must satisfy 0 < lower < 1 < upper");
  }
  const int n = static_cast<int>(indices->size());
  SuspensionParameters<double> copy = nominal;
  const std::vector<NamedParameter<double>> list = ListParameters(&copy);
  *result = EstimationResult();
  scaled->resize(n);
  for (int i = 0; i < n; ++i) {
    ParameterEstimate p;
    p.name = list[(*indices)[i]].name;
    p.unit = list[(*indices)[i]].unit;
    p.nominal = *list[(*indices)[i]].value;
    p.initial = initial[i];
    (*scaled)[i] = initial[i] / p.nominal;
    if (!((*scaled)[i] >= options.lower_scale &&
          (*scaled)[i] <= options.upper_scale)) {
      return Status::Error(
          "initial " + p.name + " = " + std::to_string(initial[i]) +
          " is outside the bounds [" + std::to_string(options.lower_scale) +
          ", " + std::to_string(options.upper_scale) + "] x nominal");
    }
    result->parameters.push_back(p);
  }
  return Status::Ok();
}

// The residuals that carry data: rows of unobserved samples (fresh = 0, the
// rig's memory) are zero.
int ObservedResiduals(const std::vector<Experiment>& experiments,
                      const EstimatorOptions& options, int rows) {
  for (const Experiment& experiment : experiments) {
    rows -= static_cast<int>(std::count(experiment.observed.begin(),
                                        experiment.observed.end(), false) *
                             options.channels.size());
  }
  return rows;
}

// The fit's adequacy, judged without the model's own discretisation error
// (returned, reported beside it), and the residual RMS per channel in SI.
Status AssessFit(const SuspensionParameters<double>& nominal,
                 const std::vector<Experiment>& experiments,
                 const EstimatorOptions& options, double integrator_step,
                 const std::vector<int>& indices,
                 const std::vector<double>& scaled,
                 const Eigen::VectorXd& residuals,
                 Eigen::VectorXd* discretisation, EstimationResult* result) {
  KCRIG_RETURN_IF_ERROR(DiscretisationError(nominal, experiments, options,
                                            integrator_step, indices, scaled,
                                            residuals, discretisation));
  const int n = static_cast<int>(indices.size());
  result->adequacy = AssessStepAndLimit(
      experiments, options.channels, residuals, *discretisation,
      [&](const Eigen::VectorXd& r) {
        return AssessAdequacy(experiments,
                              SplitResiduals(experiments, options.channels, r),
                              options.channels, n, options.adequacy);
      });
  for (int k = 0; k < 6; ++k) {
    const ChannelAdequacy& c = result->adequacy.channels[k];
    result->channel_used[k] = c.used && c.samples > 0;
  }
  result->residual_rms = ResidualRms(
      experiments, SplitResiduals(experiments, options.channels, residuals));
  return Status::Ok();
}

}  // namespace

Status Estimate(const SuspensionParameters<double>& nominal,
                const std::vector<Experiment>& experiments,
                const EstimatorOptions& options,
                const std::vector<double>& initial, double integrator_step,
                EstimationResult* result) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<int> indices;
  std::vector<double> scaled;
  KCRIG_RETURN_IF_ERROR(PreprocessEstimate(nominal, experiments, options,
                                           initial, &indices, &scaled, result));
  const int n = static_cast<int>(indices.size());

  // Minimize.
  KCRIG_RETURN_IF_ERROR(CheckFitMemory(experiments, options, n));
  FitProblem problem(nominal, experiments, options, integrator_step, indices);
  LeastSquaresSummary summary;
  KCRIG_RETURN_IF_ERROR(problem.Minimize(FitOptions(options, "estimation"), {},
                                         &scaled, &summary));
  result->cost = summary.cost;
  result->converged = summary.converged;
  result->iterations = summary.iterations;
  result->termination = summary.message;

  // Summarize: the residual and Jacobian at the solution, the adequacy, the
  // values and their uncertainty.
  Eigen::MatrixXd jacobian;
  Eigen::VectorXd residuals;
  if (!problem.Evaluate(scaled, nullptr, &residuals, &jacobian)) {
    return Status::Error("the model cannot be evaluated at the solution");
  }
  result->memory_rows = MemoryRows(experiments);
  result->initial_states = InitialStatesAtEquilibrium(experiments);
  const int m = ObservedResiduals(experiments, options,
                                  static_cast<int>(residuals.size()));
  result->num_residuals = m;
  result->sigma_hat = m > n ? std::sqrt(2.0 * result->cost / (m - n)) : 0.0;
  Eigen::VectorXd discretisation;
  KCRIG_RETURN_IF_ERROR(AssessFit(nominal, experiments, options,
                                  integrator_step, indices, scaled, residuals,
                                  &discretisation, result));
  for (int i = 0; i < n; ++i) {
    ParameterEstimate& p = result->parameters[i];
    p.value = scaled[i] * p.nominal;
    p.at_bound = problem.AtBound(i, scaled[i]);
  }
  const Eigen::VectorXd gradient = jacobian.transpose() * discretisation;
  const ResidualStructure structure =
      MeasureResidualStructure(jacobian, residuals, experiments,
                               static_cast<int>(options.channels.size()));
  AnalyzeUncertainty(std::move(jacobian), options, result);
  WidenForResidualStructure(structure, result);
  AddDiscretisationBias(gradient, result);
  result->integrator_step = integrator_step;
  result->seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  return Status::Ok();
}

Status PredictExperiments(const SuspensionParameters<double>& nominal,
                          const std::vector<Experiment>& experiments,
                          const EstimatorOptions& options,
                          const EstimationResult& result,
                          double integrator_step, Adequacy* prediction) {
  if (experiments.empty()) return Status::Error("no experiments to predict");
  std::vector<int> indices;
  KCRIG_RETURN_IF_ERROR(
      ResolveParameters(nominal, options.parameters, &indices));
  if (result.parameters.size() != indices.size()) {
    return Status::Error("the estimate does not hold the options' parameters");
  }
  std::vector<double> scaled;
  for (const ParameterEstimate& p : result.parameters) {
    // A value on its bound may round a hair outside it.
    scaled.push_back(std::clamp(p.value / p.nominal, options.lower_scale,
                                options.upper_scale));
  }
  FitProblem problem(nominal, experiments, options, integrator_step, indices);
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
  if (!problem.Evaluate(scaled, nullptr, &residuals, &jacobian)) {
    return Status::Error("the model cannot be evaluated at the estimate");
  }
  if (result.information.rows() != jacobian.cols()) {
    return Status::Error("the estimate has no information matrix");
  }
  Eigen::VectorXd discretisation;
  KCRIG_RETURN_IF_ERROR(DiscretisationError(nominal, experiments, options,
                                            integrator_step, indices, scaled,
                                            residuals, &discretisation));
  *prediction =
      AssessStepAndLimit(experiments, options.channels, residuals,
                         discretisation, [&](const Eigen::VectorXd& r) {
                           return AssessPredictionResiduals(
                               experiments, options.channels, r, jacobian,
                               result.information, options.adequacy);
                         });
  return Status::Ok();
}

}  // namespace kcrig
