#include "estimator/fit_problem.h"

#include "ceres/ceres.h"
#include "estimator/trajectory_residual.h"

namespace kcrig {

FitProblem::FitProblem(const SuspensionParameters<double>& nominal,
                       const std::vector<Experiment>& experiments,
                       const EstimatorOptions& options, double integrator_step,
                       std::vector<int> indices)
    : options_(options), scaled_(indices.size(), 1.0) {
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_ = std::make_unique<ceres::Problem>(problem_options);
  std::vector<double*> blocks;
  for (double& s : scaled_) blocks.push_back(&s);
  for (const Experiment& experiment : experiments) {
    problem_->AddResidualBlock(
        new TrajectoryResidual(&nominal, indices, options.channels, &experiment,
                               integrator_step, options.lower_scale,
                               options.upper_scale,
                               options.split_sensitivities),
        nullptr, blocks);
  }
}

FitProblem::~FitProblem() = default;

Status FitProblem::Minimize(const std::vector<bool>& fixed,
                            std::vector<double>* scaled, double* cost,
                            bool* converged, int* iterations,
                            std::string* message) {
  scaled_ = *scaled;
  int free = 0;
  for (size_t i = 0; i < scaled_.size(); ++i) {
    if (fixed[i]) {
      problem_->SetParameterBlockConstant(&scaled_[i]);
    } else {
      problem_->SetParameterBlockVariable(&scaled_[i]);
      ++free;
    }
  }
  if (free == 0) {
    if (!Cost(*scaled, cost)) {
      return Status::Error("the model cannot be evaluated at these parameters");
    }
    if (converged != nullptr) *converged = true;
    if (iterations != nullptr) *iterations = 0;
    return Status::Ok();
  }
  ceres::Solver::Options solver;
  solver.minimizer_type = ceres::TRUST_REGION;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = options_.max_iterations;
  solver.function_tolerance = options_.function_tolerance;
  solver.gradient_tolerance = options_.gradient_tolerance;
  solver.parameter_tolerance = options_.parameter_tolerance;
  solver.num_threads = options_.num_threads;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, problem_.get(), &summary);
  if (summary.termination_type == ceres::FAILURE ||
      !std::isfinite(summary.final_cost)) {
    return Status::Error("estimation failed: " + summary.message);
  }
  *scaled = scaled_;
  *cost = summary.final_cost;
  if (converged != nullptr) {
    *converged = summary.termination_type == ceres::CONVERGENCE;
  }
  if (iterations != nullptr) {
    *iterations = static_cast<int>(summary.iterations.size()) - 1;
  }
  if (message != nullptr) *message = summary.message;
  return Status::Ok();
}

bool FitProblem::Cost(const std::vector<double>& scaled, double* cost) {
  scaled_ = scaled;
  ceres::Problem::EvaluateOptions options;
  for (double& s : scaled_) options.parameter_blocks.push_back(&s);
  return problem_->Evaluate(options, cost, nullptr, nullptr, nullptr);
}

bool FitProblem::Evaluate(const std::vector<double>& scaled,
                          Eigen::MatrixXd* jacobian,
                          Eigen::VectorXd* residuals) {
  scaled_ = scaled;
  ceres::Problem::EvaluateOptions options;
  for (double& s : scaled_) options.parameter_blocks.push_back(&s);
  double cost = 0;
  std::vector<double> r;
  ceres::CRSMatrix crs;
  if (!problem_->Evaluate(options, &cost, &r, nullptr, &crs)) return false;
  jacobian->setZero(crs.num_rows, crs.num_cols);
  for (int row = 0; row < crs.num_rows; ++row) {
    for (int k = crs.rows[row]; k < crs.rows[row + 1]; ++k) {
      (*jacobian)(row, crs.cols[k]) = crs.values[k];
    }
  }
  *residuals = Eigen::Map<Eigen::VectorXd>(r.data(), r.size());
  return true;
}

}  // namespace kcrig
