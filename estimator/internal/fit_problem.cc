#include "estimator/internal/fit_problem.h"

#include <utility>

#include "estimator/trajectory_residual.h"

namespace kcrig {

FitProblem::FitProblem(const SuspensionParameters<double>& nominal,
                       const std::vector<Experiment>& experiments,
                       const EstimatorOptions& options, double integrator_step,
                       const std::vector<int>& indices)
    : LeastSquaresProblem(
          std::vector<double>(indices.size(), options.lower_scale),
          std::vector<double>(indices.size(), options.upper_scale)) {
  for (const Experiment& experiment : experiments) {
    AddResidualBlock(new TrajectoryResidual(
        &nominal, indices, options.channels, &experiment, integrator_step,
        options.lower_scale, options.upper_scale));
  }
}

LeastSquaresOptions FitOptions(const EstimatorOptions& options,
                               std::string stage) {
  LeastSquaresOptions fit;
  fit.max_iterations = options.max_iterations;
  fit.function_tolerance = options.function_tolerance;
  fit.gradient_tolerance = options.gradient_tolerance;
  fit.parameter_tolerance = options.parameter_tolerance;
  fit.num_threads = options.num_threads;
  fit.stage = std::move(stage);
  fit.callback = options.callback;
  return fit;
}

}  // namespace kcrig
