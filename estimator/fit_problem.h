// The least-squares problem of eq. (6) over a set of experiments as one
// reusable Ceres problem: minimize over any subset of the parameters (the
// rest held), evaluate residuals and the weighted Jacobian anywhere.
// Used by Estimate, the profile likelihood and screening.
#ifndef KCRIG_ESTIMATOR_FIT_PROBLEM_H_
#define KCRIG_ESTIMATOR_FIT_PROBLEM_H_

#include <memory>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "estimator/estimator.h"

namespace ceres {
class Problem;
}

namespace kcrig {

class FitProblem {
 public:
  // `indices` from ResolveParameters. All references must outlive this.
  FitProblem(const SuspensionParameters<double>& nominal,
             const std::vector<Experiment>& experiments,
             const EstimatorOptions& options, double integrator_step,
             std::vector<int> indices);
  ~FitProblem();

  int num_parameters() const { return static_cast<int>(scaled_.size()); }

  // Levenberg-Marquardt from `scaled` (p / p_nominal) over the parameters
  // whose `fixed` entry is false; writes the solution back. `iterations`
  // and `message` may be null.
  Status Minimize(const std::vector<bool>& fixed, std::vector<double>* scaled,
                  double* cost, bool* converged, int* iterations,
                  std::string* message);

  // 0.5 |f|^2 at `scaled`; false when the model cannot be evaluated there.
  bool Cost(const std::vector<double>& scaled, double* cost);

  // Weighted residuals and Jacobian (scaled parameters) at `scaled`.
  bool Evaluate(const std::vector<double>& scaled, Eigen::MatrixXd* jacobian,
                Eigen::VectorXd* residuals);

 private:
  const EstimatorOptions& options_;
  std::vector<double> scaled_;  // the parameter blocks Ceres works on
  std::unique_ptr<ceres::Problem> problem_;
};

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_FIT_PROBLEM_H_
