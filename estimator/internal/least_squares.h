// The one weighted nonlinear least-squares fit of the offline half, for the
// trajectory residual of eq. (6) (fit_problem.h) and the diagnosis' effect
// models alike: the Ceres problem on a box with one parameter block per
// parameter (any of them can be held), projected Levenberg-Marquardt with
// an active set that an IterationCallback can stop, the dense weighted
// Jacobian anywhere, and the rule for a parameter that ended on its bound.
//
// The box is kept by projection: every residual is evaluated at the
// projection of the parameters onto it, with a zero Jacobian column for a
// parameter beyond its bound. A step that would cross a bound lands on it
// instead of being rejected whole (which stalled the fit of the others, or
// made it crawl towards the bound in ever smaller steps); a parameter the
// data push outward stays on its bound, and the next round of the solve
// holds it there (released again when the gradient turns inward).
#ifndef KCRIG_ESTIMATOR_INTERNAL_LEAST_SQUARES_H_
#define KCRIG_ESTIMATOR_INTERNAL_LEAST_SQUARES_H_

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
  // The box lower[i] <= x_i <= upper[i] (lower[i] <= upper[i]).
  LeastSquaresProblem(std::vector<double> lower, std::vector<double> upper);
  virtual ~LeastSquaresProblem();
  LeastSquaresProblem(const LeastSquaresProblem&) = delete;
  LeastSquaresProblem& operator=(const LeastSquaresProblem&) = delete;

  // Adds `residual` (owned), which takes one parameter block of size 1 per
  // parameter, in order; it is only ever evaluated inside the box.
  void AddResidualBlock(ceres::CostFunction* residual);

  int num_parameters() const { return static_cast<int>(x_.size()); }

  // Levenberg-Marquardt from *x (projected onto the box) over the
  // parameters whose `fixed` entry is false (empty: all free); writes the
  // solution, inside the box, to *x. `summary` adds up the rounds.
  Status Minimize(const LeastSquaresOptions& options,
                  const std::vector<bool>& fixed, std::vector<double>* x,
                  LeastSquaresSummary* summary);

  // At the projection of `x` onto the box: the cost 0.5 |f|^2, the weighted
  // residuals f and their dense Jacobian (zero columns for the parameters
  // beyond their bounds), each output optional (null); false when the model
  // cannot be evaluated there.
  bool Evaluate(const std::vector<double>& x, double* cost,
                Eigen::VectorXd* residuals, Eigen::MatrixXd* jacobian);

  // Whether x_i is within 0.1 % of one of its bounds (of the bound's own
  // size; of the box's width at a bound of zero): there the box, not the
  // data, set the value.
  bool AtBound(int i, double x_i) const;

 private:
  // One Levenberg-Marquardt solve from x_ over the parameters not `frozen`,
  // at most `max_iterations`, its iterations reported from `first_iteration`.
  Status Solve(const LeastSquaresOptions& options,
               const std::vector<bool>& frozen, int first_iteration,
               int max_iterations, LeastSquaresSummary* summary);
  // At x_, the projection of `unprojected` where a solve ended (or the
  // start): which parameters the data push out of the box (*held, which
  // comes in as the set the solve held), and whether a round must follow:
  // one that was held or beyond its bound is now pulled back in, or one
  // stayed free on its bound while pushed out. False when the model cannot
  // be evaluated at x_.
  bool NextActiveSet(const std::vector<bool>& fixed,
                     const std::vector<double>& unprojected,
                     std::vector<bool>* held, bool* another_round);

  std::vector<double> lower_, upper_;
  std::vector<double> x_;  // the parameter blocks Ceres works on
  std::unique_ptr<ceres::Problem> problem_;
  // The blocks added, in order (owned by problem_).
  std::vector<const ceres::CostFunction*> residual_blocks_;
};

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_INTERNAL_LEAST_SQUARES_H_
