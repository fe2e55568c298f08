#include "estimator/internal/fit_problem.h"

#include <algorithm>
#include <cstdio>
#include <utility>

#include "base/available_memory.h"
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
    AddResidualBlock(new TrajectoryResidual(&nominal, indices, options.channels,
                                            &experiment, integrator_step));
  }
}

std::uint64_t FitMemoryBytes(const std::vector<Experiment>& experiments,
                             int num_channels, int num_parameters) {
  constexpr std::uint64_t kPerSample =
      sizeof(Vec3<double>) + sizeof(Vec6<double>) + sizeof(double);
  const std::uint64_t per_residual = 8 * (4 * num_parameters + 12);
  std::uint64_t samples = 0;
  for (const Experiment& e : experiments) samples += e.measured.size();
  return samples * (kPerSample + num_channels * per_residual);
}

Status CheckFitMemory(const std::vector<Experiment>& experiments,
                      const EstimatorOptions& options, int num_parameters) {
  const std::uint64_t need = FitMemoryBytes(
      experiments, static_cast<int>(options.channels.size()), num_parameters);
  const std::uint64_t budget = options.memory_budget_bytes > 0
                                   ? options.memory_budget_bytes
                                   : AvailableMemoryBytes();
  if (need <= budget || experiments.empty()) return Status::Ok();
  const Experiment& longest =
      *std::max_element(experiments.begin(), experiments.end(),
                        [](const Experiment& a, const Experiment& b) {
                          return a.measured.size() < b.measured.size();
                        });
  size_t samples = 0;
  for (const Experiment& e : experiments) samples += e.measured.size();
  const std::string others =
      experiments.size() > 1
          ? " and " + std::to_string(experiments.size() - 1) + " other log(s)"
          : "";
  char text[256];
  std::snprintf(text, sizeof(text),
                ": fitting %d parameters to %zu samples needs about %.2f GiB "
                "of memory and %.2f GiB are available: fit a shorter part of "
                "the log, or fewer channels",
                num_parameters, samples, need / 1073741824.0,
                budget / 1073741824.0);
  return Status::Error(longest.source + others + text);
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
