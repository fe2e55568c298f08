// The least-squares problem of eq. (6) over a set of experiments in scaled
// parameters p / p_nominal on the box [lower_scale, upper_scale]: the
// trajectory residuals in the one least-squares fit (least_squares.h).
// Used by Estimate, the profile likelihood and screening.
#ifndef KCRIG_ESTIMATOR_INTERNAL_FIT_PROBLEM_H_
#define KCRIG_ESTIMATOR_INTERNAL_FIT_PROBLEM_H_

#include <cstdint>
#include <string>
#include <vector>

#include "estimator/estimator.h"
#include "estimator/internal/least_squares.h"

namespace kcrig {

class FitProblem : public LeastSquaresProblem {
 public:
  // `indices` from ResolveParameters. All references must outlive this.
  FitProblem(const SuspensionParameters<double>& nominal,
             const std::vector<Experiment>& experiments,
             const EstimatorOptions& options, double integrator_step,
             const std::vector<int>& indices);
};

// The heap a fit of `num_parameters` over `experiments` holds at its peak,
// in the Levenberg-Marquardt solve: per residual (sample x channel) four
// copies of its Jacobian row (Ceres' Jacobian, its evaluation scratch and
// its QR's copy, the residual's cache of its last evaluation) and about
// twelve residual vectors; per sample, the experiment itself. Measured
// 1485 B per sample for six channels and five parameters; this says 1616.
std::uint64_t FitMemoryBytes(const std::vector<Experiment>& experiments,
                             int num_channels, int num_parameters);

// An error naming the longest log when FitMemoryBytes exceeds
// options.memory_budget_bytes (0: AvailableMemoryBytes()).
Status CheckFitMemory(const std::vector<Experiment>& experiments,
                      const EstimatorOptions& options, int num_parameters);

// The Levenberg-Marquardt limits, threads and callback of `options` for a
// fit named `stage`.
LeastSquaresOptions FitOptions(const EstimatorOptions& options,
                               std::string stage);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_INTERNAL_FIT_PROBLEM_H_
