// The last residuals and Jacobian columns of a cost function whose
// parameters are blocks of size 1, with the parameters they were evaluated
// at. Ceres evaluates the Jacobian at every accepted point, and the
// uncertainty analysis asks again at the final one: that second trajectory
// with sensitivities is served from here. Thread-safe.
#ifndef KCRIG_ESTIMATOR_JACOBIAN_CACHE_H_
#define KCRIG_ESTIMATOR_JACOBIAN_CACHE_H_

#include <functional>
#include <mutex>
#include <vector>

namespace kcrig {

class JacobianCache {
 public:
  // Fills `residuals` and the non-null `jacobians[i]` (num_residuals each)
  // at `parameters` (num_parameters blocks of size 1): from the cache when
  // it was filled at exactly these parameters, otherwise by `evaluate`,
  // which gets every column and fills the cache. False when `evaluate`
  // fails (the cache is then empty).
  using Evaluation = std::function<bool(double* residuals, double** columns)>;
  bool Evaluate(double const* const* parameters, int num_parameters,
                int num_residuals, double* residuals, double** jacobians,
                const Evaluation& evaluate);

 private:
  bool Holds(double const* const* parameters, int num_parameters) const;

  std::mutex mutex_;
  bool filled_ = false;  // by a successful evaluation at parameters_
  std::vector<double> parameters_;
  std::vector<double> residuals_;
  std::vector<std::vector<double>> columns_;
};

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_JACOBIAN_CACHE_H_
