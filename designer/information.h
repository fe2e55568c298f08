// The information matrix of eq. (9), I(p*, v) = J^T J, of one ramp
// experiment with design v = (phi, z_a), at the current parameter estimate
// p*. J is the Jacobian of the estimator's weighted residuals (eq. 6,
// divided by the sensor sigmas) by the scaled parameters s = p / p_nominal,
// so I^-1 is the covariance of s the estimator would report: its diagonal is
// the relative variance of each parameter.
#ifndef KCRIG_DESIGNER_INFORMATION_H_
#define KCRIG_DESIGNER_INFORMATION_H_

#include <memory>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "base/status.h"
#include "estimator/experiment.h"
#include "rt_core/model/model_config.h"
#include "rt_core/model/suspension_parameters.h"

namespace kcrig {

// A design of the ramp experiment (paper section 5): force direction in the
// x-y plane and acting height relative to the wheel centre.
struct Design {
  double phi = 0;  // [rad]
  double z_a = 0;  // [m]
};

struct DesignBounds {
  Interval phi;  // [rad]
  Interval z_a;  // [m]
};

// Inverted or empty bounds are an error naming the bound.
Status ValidateBounds(const DesignBounds& bounds);

// `design` in the optimizers' unit coordinates: [0, 1]^2 over `bounds`.
inline Eigen::Vector2d ToUnit(const DesignBounds& bounds,
                              const Design& design) {
  return Eigen::Vector2d(
      (design.phi - bounds.phi.lower) / (bounds.phi.upper - bounds.phi.lower),
      (design.z_a - bounds.z_a.lower) / (bounds.z_a.upper - bounds.z_a.lower));
}

class InformationEvaluator {
 public:
  // `nominal`: the config model (its values are the parameter scales and
  // hold every parameter that is not estimated). `names`/`values`: the
  // estimated parameters at the current estimate (physical units).
  // `experiment`: Fmax, ramp time, rate, integrator step and sigmas of the
  // next experiment. `prior`: information already collected (n x n, e.g.
  // J^T J of the logs so far) added to every evaluation; empty for none.
  InformationEvaluator(const SuspensionParameters<double>& nominal,
                       std::vector<int> parameter_indices,
                       std::vector<double> scaled_values,
                       const ExperimentConfig& experiment,
                       Eigen::MatrixXd prior);

  // Checks the names, values and prior and builds the evaluator.
  static Status Create(const SuspensionParameters<double>& nominal,
                       const std::vector<std::string>& names,
                       const std::vector<double>& values,
                       const ExperimentConfig& experiment,
                       const Eigen::MatrixXd& prior,
                       std::unique_ptr<InformationEvaluator>* evaluator);

  int num_parameters() const {
    return static_cast<int>(parameter_indices_.size());
  }

  // prior + J^T J with the exact sensitivities of the discrete trajectory.
  Status Information(const Design& design, Eigen::MatrixXd* information) const;

  // prior + J^T J with J by forward differences, step `relative_step` x s_i:
  // the finite-difference criterion of the paper, for comparison.
  Status FiniteDifferenceInformation(const Design& design, double relative_step,
                                     Eigen::MatrixXd* information) const;

  // The experiment the design stands for, driven by the exact ramp.
  Experiment MakeExperiment(const Design& design) const;

 private:
  // The columns of J: exact sensitivities when `relative_step` is 0,
  // else forward differences with step relative_step x s_i.
  Status JacobianColumns(const Design& design, double relative_step,
                         std::vector<std::vector<double>>* columns) const;

  SuspensionParameters<double> nominal_;
  std::vector<int> parameter_indices_;
  std::vector<double> scaled_values_;
  ExperimentConfig experiment_;
  Eigen::MatrixXd prior_;
};

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_INFORMATION_H_
