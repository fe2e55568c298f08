// The least-squares problem of eq. (6) over a set of experiments in scaled
// parameters p / p_nominal on the box [lower_scale, upper_scale]: the
// trajectory residuals in the one least-squares fit (least_squares.h).
// Used by Estimate, the profile likelihood and screening.
#ifndef KCRIG_ESTIMATOR_INTERNAL_FIT_PROBLEM_H_
#define KCRIG_ESTIMATOR_INTERNAL_FIT_PROBLEM_H_

#include <string>
#include <vector>

#include "estimator/estimator.h"
#include "estimator/least_squares.h"

namespace kcrig {

class FitProblem : public LeastSquaresProblem {
 public:
  // `indices` from ResolveParameters. All references must outlive this.
  FitProblem(const SuspensionParameters<double>& nominal,
             const std::vector<Experiment>& experiments,
             const EstimatorOptions& options, double integrator_step,
             const std::vector<int>& indices);
};

// The Levenberg-Marquardt limits, threads and callback of `options` for a
// fit named `stage`.
LeastSquaresOptions FitOptions(const EstimatorOptions& options,
                               std::string stage);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_INTERNAL_FIT_PROBLEM_H_
