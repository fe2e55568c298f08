// The weighted residuals of eq. (6) of the paper for one experiment,
//   f_jk(s) = (x_k(t_j, p(s)) - eta_jk) / sigma_k,
// over the selected channels k, as a Ceres cost function whose Jacobian is
// the exact sensitivity of the discrete semi-implicit Euler solution (the
// tangent-linear step of rt_core/model/tangent_linear.h, equal to ceres::Jet
// through the whole trajectory; no finite differences).
// Parameters are scaled, s_i = p_i / p_i,nominal, one parameter block of
// size 1 each so that any of them can be held constant (profiles).
// The box of s is LeastSquaresProblem's: it evaluates this only inside.
#ifndef KCRIG_ESTIMATOR_TRAJECTORY_RESIDUAL_H_
#define KCRIG_ESTIMATOR_TRAJECTORY_RESIDUAL_H_

#include <string>
#include <vector>

#include "ceres/cost_function.h"
#include "estimator/experiment.h"
#include "estimator/jacobian_cache.h"
#include "rt_core/model/suspension_parameters.h"

namespace kcrig {

// Most parameters estimated at once (the Jet size is chosen per problem).
inline constexpr int kMaxEstimatedParameters = 8;

class TrajectoryResidual : public ceres::CostFunction {
 public:
  // `parameter_names` index into ListParameters(); their nominal values
  // (non-zero) come from `nominal`. `channels` are indices 0..5 of
  // x, y, z, toe, camber, caster. All pointers must outlive this object.
  TrajectoryResidual(const SuspensionParameters<double>* nominal,
                     std::vector<int> parameter_indices,
                     std::vector<int> channels, const Experiment* experiment,
                     double integrator_step);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  int num_samples() const {
    return static_cast<int>(experiment_->measured.size());
  }

 private:
  // Simulates the experiment at `parameters` with scalar T (double, or a Jet
  // whose slot i is the derivative by parameter i) and writes the residuals
  // and, for Jets, every Jacobian column (none may be null).
  template <typename T>
  bool SimulateAndFill(double const* const* parameters, double* residuals,
                       double** jacobians) const;

  const SuspensionParameters<double>* nominal_;
  std::vector<int> parameter_indices_;
  std::vector<int> channels_;
  const Experiment* experiment_;
  double integrator_step_;

  // The Jacobian Ceres evaluated last, for the uncertainty analysis.
  mutable JacobianCache cache_;
};

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_TRAJECTORY_RESIDUAL_H_
