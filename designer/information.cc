#include "designer/information.h"

#include <cmath>
#include <memory>
#include <utility>

#include "estimator/estimator.h"
#include "estimator/trajectory_residual.h"
#include "rt_core/model/excitation.h"

namespace kcrig {
namespace {

// The estimator's box on the scaled parameters; a design is evaluated inside.
constexpr double kLowerScale = 0.1;
constexpr double kUpperScale = 10.0;

Eigen::MatrixXd Gram(const std::vector<std::vector<double>>& columns) {
  const int n = static_cast<int>(columns.size());
  Eigen::MatrixXd gram(n, n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Map<const Eigen::VectorXd> a(columns[i].data(),
                                              columns[i].size());
    for (int j = 0; j <= i; ++j) {
      const Eigen::Map<const Eigen::VectorXd> b(columns[j].data(),
                                                columns[j].size());
      gram(i, j) = gram(j, i) = a.dot(b);
    }
  }
  return gram;
}

}  // namespace

Status ValidateBounds(const DesignBounds& bounds) {
  if (!std::isfinite(bounds.phi.lower) || !std::isfinite(bounds.phi.upper) ||
      !(bounds.phi.lower < bounds.phi.upper)) {
    return Status::Error(
        "design bounds: phi lower must be below phi upper (both finite)");
  }
  if (!std::isfinite(bounds.z_a.lower) || !std::isfinite(bounds.z_a.upper) ||
      !(bounds.z_a.lower < bounds.z_a.upper)) {
    return Status::Error(
        "design bounds: z_a lower must be below z_a upper (both finite)");
  }
  return Status::Ok();
}

InformationEvaluator::InformationEvaluator(
    const SuspensionParameters<double>& nominal,
    std::vector<int> parameter_indices, std::vector<double> scaled_values,
    const ExperimentConfig& experiment, Eigen::MatrixXd prior)
    : nominal_(nominal),
      parameter_indices_(std::move(parameter_indices)),
      scaled_values_(std::move(scaled_values)),
      experiment_(experiment),
      prior_(std::move(prior)) {}

Status InformationEvaluator::Create(
    const SuspensionParameters<double>& nominal,
    const std::vector<std::string>& names, const std::vector<double>& values,
    const ExperimentConfig& experiment, const Eigen::MatrixXd& prior,
    std::unique_ptr<InformationEvaluator>* evaluator) {
  std::vector<int> indices;
  Status status = ResolveParameters(nominal, names, &indices);
  if (!status.ok()) return status;
  if (values.size() != names.size()) {
    return Status::Error("design: " + std::to_string(names.size()) +
                         " parameters but " + std::to_string(values.size()) +
                         " values");
  }
  const std::vector<double> scales = ParameterValues(nominal, indices);
  std::vector<double> scaled;
  for (size_t i = 0; i < names.size(); ++i) {
    const double s = values[i] / scales[i];
    if (!std::isfinite(s) || s < kLowerScale || s > kUpperScale) {
      return Status::Error("design: " + names[i] + " = " +
                           std::to_string(values[i]) +
                           " is not within 0.1 .. 10 x its config value");
    }
    scaled.push_back(s);
  }
  const int n = static_cast<int>(names.size());
  if (prior.size() != 0 &&
      (prior.rows() != n || prior.cols() != n || !prior.allFinite())) {
    return Status::Error("design: the prior information matrix must be " +
                         std::to_string(n) + " x " + std::to_string(n) +
                         " and finite");
  }
  if (!(experiment.fmax >= 0) || !(experiment.duration > 0) ||
      !(experiment.rate > 0) || !(experiment.step > 0) ||
      !(experiment.sigma_position > 0) || !(experiment.sigma_angle > 0)) {
    return Status::Error(
        "design: the experiment needs fmax >= 0, duration, rate, step and "
        "sigmas > 0");
  }
  *evaluator = std::make_unique<InformationEvaluator>(
      nominal, std::move(indices), std::move(scaled), experiment,
      prior.size() == 0 ? Eigen::MatrixXd::Zero(n, n) : prior);
  return Status::Ok();
}

Experiment InformationEvaluator::MakeExperiment(const Design& design) const {
  return PlannedExperiment(experiment_.Excitation(design.phi, design.z_a),
                           experiment_);
}

Status InformationEvaluator::Information(const Design& design,
                                         Eigen::MatrixXd* information) const {
  std::vector<std::vector<double>> columns;
  const Status status = JacobianColumns(design, 0.0, &columns);
  if (!status.ok()) return status;
  *information = prior_ + Gram(columns);
  return Status::Ok();
}

Status InformationEvaluator::FiniteDifferenceInformation(
    const Design& design, double relative_step,
    Eigen::MatrixXd* information) const {
  std::vector<std::vector<double>> columns;
  const Status status = JacobianColumns(design, relative_step, &columns);
  if (!status.ok()) return status;
  *information = prior_ + Gram(columns);
  return Status::Ok();
}

Status InformationEvaluator::JacobianColumns(
    const Design& design, double relative_step,
    std::vector<std::vector<double>>* columns) const {
  const Experiment experiment = MakeExperiment(design);
  const TrajectoryResidual residual(&nominal_, parameter_indices_,
                                    {0, 1, 2, 3, 4, 5}, &experiment,
                                    experiment_.step);
  const int n = num_parameters();
  const int m = residual.num_residuals();
  std::vector<double> values = scaled_values_;
  std::vector<const double*> blocks(n);
  for (int i = 0; i < n; ++i) blocks[i] = &values[i];
  std::vector<double> residuals(m);
  columns->assign(n, std::vector<double>(m));
  const Status diverged = Status::Error(
      "design: the model diverged at phi " + std::to_string(design.phi) +
      " rad, z_a " + std::to_string(design.z_a) + " m");
  if (relative_step == 0) {
    std::vector<double*> jacobians(n);
    for (int i = 0; i < n; ++i) jacobians[i] = (*columns)[i].data();
    if (!residual.Evaluate(blocks.data(), residuals.data(), jacobians.data())) {
      return diverged;
    }
    return Status::Ok();
  }
  if (!residual.Evaluate(blocks.data(), residuals.data(), nullptr)) {
    return diverged;
  }
  for (int i = 0; i < n; ++i) {
    std::vector<double>& column = (*columns)[i];
    const double step = relative_step * scaled_values_[i];
    values[i] = scaled_values_[i] + step;
    if (!residual.Evaluate(blocks.data(), column.data(), nullptr)) {
      return diverged;
    }
    values[i] = scaled_values_[i];
    for (int r = 0; r < m; ++r) column[r] = (column[r] - residuals[r]) / step;
  }
  return Status::Ok();
}

}  // namespace kcrig
