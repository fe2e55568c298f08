// The one weighted nonlinear least-squares fit of the offline half, for the
// trajectory residual of eq. (6) (fit_problem.h) and the diagnosis' effect
// models alike: the Ceres problem on a box with one parameter block per
// parameter (any of them can be held), Levenberg-Marquardt that an
// IterationCallback can stop, the dense weighted Jacobian anywhere, and the
// rule for a parameter that ended on its bound.
#ifndef KCRIG_ESTIMATOR_LEAST_SQUARES_H_
#define KCRIG_ESTIMATOR_LEAST_SQUARES_H_

#include <memory>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "base/iteration_callback.h"
#include "base/status.h"

namespace ceres {
class CostFunction;
class Problem;
}  // namespace ceres

namespace kcrig {

struct LeastSquaresOptions {
  // Levenberg-Marquardt limits, as ceres::Solver::Options names them.
  int max_iterations = 100;
  double function_tolerance = 1e-10;
  double gradient_tolerance = 1e-16;
  double parameter_tolerance = 1e-12;
  // Residual blocks are evaluated on this many threads.
  int num_threads = 1;
  // Names the fit in its errors and progress: "estimation", "fitting the
  // hysteresis model".
  std::string stage = "least squares";
  // Asked after every iteration ("<stage>: iteration k", k of
  // max_iterations); kAbort stops the solve and Minimize returns
  // Interrupted(stage). Optional.
  IterationCallback callback;
};

struct LeastSquaresSummary {
  double cost = 0;  // 0.5 |f|^2 at the solution
  int iterations = 0;
  bool converged = false;  // Ceres' CONVERGENCE, not a limit
  std::string message;     // Ceres' termination message
};

class LeastSquaresProblem {
 public:
  // The box lower[i] <= x_i <= upper[i]. The residuals enforce it (a point
  // outside is an invalid step, see trajectory_residual.h); here it only
  // decides AtBound.
  LeastSquaresProblem(std::vector<double> lower, std::vector<double> upper);
  virtual ~LeastSquaresProblem();
  LeastSquaresProblem(const LeastSquaresProblem&) = delete;
  LeastSquaresProblem& operator=(const LeastSquaresProblem&) = delete;

  // Adds `residual` (owned), which takes one parameter block of size 1 per
  // parameter, in order.
  void AddResidualBlock(ceres::CostFunction* residual);

  int num_parameters() const { return static_cast<int>(x_.size()); }

  // Levenberg-Marquardt from *x over the parameters whose `fixed` entry is
  // false (empty: all free); writes the solution to *x.
  Status Minimize(const LeastSquaresOptions& options,
                  const std::vector<bool>& fixed, std::vector<double>* x,
                  LeastSquaresSummary* summary);

  // At `x`: the cost 0.5 |f|^2, the weighted residuals f and their dense
  // Jacobian, each output optional (null); false when the model cannot be
  // evaluated there.
  bool Evaluate(const std::vector<double>& x, double* cost,
                Eigen::VectorXd* residuals, Eigen::MatrixXd* jacobian);

  // Whether x_i is within 0.1 % of one of its bounds (of the bound's own
  // size; of the box's width at a bound of zero): there the box, not the
  // data, set the value.
  bool AtBound(int i, double x_i) const;

 private:
  std::vector<double> lower_, upper_;
  std::vector<double> x_;  // the parameter blocks Ceres works on
  std::unique_ptr<ceres::Problem> problem_;
  // The blocks added, in order (owned by problem_).
  std::vector<const ceres::CostFunction*> residual_blocks_;
};

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_LEAST_SQUARES_H_
