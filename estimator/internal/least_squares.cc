#include "estimator/internal/least_squares.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <utility>

#include "ceres/ceres.h"

namespace kcrig {
namespace {

// Rounds of the active set: a round follows only when the data pull a
// parameter back from its bound, which few faces of the box ever do.
constexpr int kMaxActiveSetRounds = 4;

// The caller's IterationCallback as Ceres' own, which can abort the solve;
// the iterations count on across the rounds.
class CallbackAdapter : public ceres::IterationCallback {
 public:
  CallbackAdapter(const LeastSquaresOptions& options, int first_iteration)
      : options_(options), first_iteration_(first_iteration) {}

  ceres::CallbackReturnType operator()(
      const ceres::IterationSummary& iteration) override {
    IterationSummary summary;
    summary.done = first_iteration_ + iteration.iteration;
    summary.stage =
        options_.stage + ": iteration " + std::to_string(summary.done);
    summary.total = options_.max_iterations;
    return options_.callback(summary) == CallbackReturn::kAbort
               ? ceres::SOLVER_ABORT
               : ceres::SOLVER_CONTINUE;
  }

 private:
  const LeastSquaresOptions& options_;
  int first_iteration_;
};

void Project(const std::vector<double>& lower, const std::vector<double>& upper,
             std::vector<double>* x) {
  for (size_t i = 0; i < x->size(); ++i) {
    (*x)[i] = std::clamp((*x)[i], lower[i], upper[i]);
  }
}

// A residual block evaluated at the projection of its parameters onto the
// box, with a zero Jacobian column for a parameter beyond its bound (there
// it has no effect).
class ProjectedResidual : public ceres::CostFunction {
 public:
  ProjectedResidual(ceres::CostFunction* inner, std::vector<double> lower,
                    std::vector<double> upper)
      : inner_(inner), lower_(std::move(lower)), upper_(std::move(upper)) {
    *mutable_parameter_block_sizes() = inner->parameter_block_sizes();
    set_num_residuals(inner->num_residuals());
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    std::vector<double> projected(lower_.size());
    for (size_t i = 0; i < projected.size(); ++i) {
      if (!std::isfinite(parameters[i][0])) return false;
      projected[i] = parameters[i][0];
    }
    Project(lower_, upper_, &projected);
    std::vector<const double*> blocks;
    for (const double& p : projected) blocks.push_back(&p);
    if (!inner_->Evaluate(blocks.data(), residuals, jacobians)) return false;
    for (size_t i = 0; jacobians != nullptr && i < projected.size(); ++i) {
      if (jacobians[i] != nullptr && projected[i] != parameters[i][0]) {
        std::fill_n(jacobians[i], num_residuals(), 0.0);
      }
    }
    return true;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
  std::vector<double> lower_, upper_;
};

}  // namespace

LeastSquaresProblem::LeastSquaresProblem(std::vector<double> lower,
                                         std::vector<double> upper)
    : lower_(std::move(lower)), upper_(std::move(upper)), x_(lower_.size()) {
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_ = std::make_unique<ceres::Problem>(problem_options);
}

LeastSquaresProblem::~LeastSquaresProblem() = default;

void LeastSquaresProblem::AddResidualBlock(ceres::CostFunction* residual) {
  std::vector<double*> blocks;
  for (double& x : x_) blocks.push_back(&x);
  auto* projected = new ProjectedResidual(residual, lower_, upper_);
  problem_->AddResidualBlock(projected, nullptr, blocks);
  residual_blocks_.push_back(projected);
}

Status LeastSquaresProblem::Minimize(const LeastSquaresOptions& options,
                                     const std::vector<bool>& fixed,
                                     std::vector<double>* x,
                                     LeastSquaresSummary* summary) {
  *summary = LeastSquaresSummary();
  x_ = *x;
  Project(lower_, upper_, &x_);
  // The start's own faces: a parameter the data push out from its start is
  // held from the first round (free, every step would move it outward and
  // the solve could stall on rejected steps). The Jacobian evaluated here
  // is the one Ceres starts from (the residuals cache it).
  std::vector<bool> held(x_.size(), false), frozen(x_.size());
  bool another_round = false;
  NextActiveSet(fixed, x_, &held, &another_round);
  for (int round = 0; round < kMaxActiveSetRounds; ++round) {
    for (size_t i = 0; i < x_.size(); ++i) {
      frozen[i] = (!fixed.empty() && fixed[i]) || held[i];
    }
    LeastSquaresSummary part;
    KCRIG_RETURN_IF_ERROR(Solve(options, frozen, summary->iterations,
                                options.max_iterations - summary->iterations,
                                &part));
    summary->iterations += part.iterations;
    summary->cost = part.cost;
    summary->converged = part.converged;
    summary->message = part.message;
    const std::vector<double> unprojected = x_;
    Project(lower_, upper_, &x_);
    if (!NextActiveSet(fixed, unprojected, &held, &another_round) ||
        !another_round || summary->iterations >= options.max_iterations) {
      another_round = false;
      break;
    }
  }
  if (another_round) {  // the rounds ran out with the active set unsettled
    summary->converged = false;
    summary->message = "the active set of the box did not settle in " +
                       std::to_string(kMaxActiveSetRounds) + " rounds";
  }
  *x = x_;
  return Status::Ok();
}

Status LeastSquaresProblem::Solve(const LeastSquaresOptions& options,
                                  const std::vector<bool>& frozen,
                                  int first_iteration, int max_iterations,
                                  LeastSquaresSummary* summary) {
  int free = 0;
  for (size_t i = 0; i < x_.size(); ++i) {
    if (frozen[i]) {
      problem_->SetParameterBlockConstant(&x_[i]);
    } else {
      problem_->SetParameterBlockVariable(&x_[i]);
      ++free;
    }
  }
  if (free == 0) {
    if (!Evaluate(std::vector<double>(x_), &summary->cost, nullptr, nullptr)) {
      return Status::Error("the model cannot be evaluated at these parameters");
    }
    summary->converged = true;
    return Status::Ok();
  }
  ceres::Solver::Options solver;
  solver.minimizer_type = ceres::TRUST_REGION;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = max_iterations;
  solver.function_tolerance = options.function_tolerance;
  solver.gradient_tolerance = options.gradient_tolerance;
  solver.parameter_tolerance = options.parameter_tolerance;
  // Ceres keeps a Jacobian scratch per thread the size of the largest
  // residual block (a whole log): threads beyond the blocks only cost memory.
  solver.num_threads =
      std::max(1, std::min(options.num_threads, problem_->NumResidualBlocks()));
  solver.logging_type = ceres::SILENT;
  CallbackAdapter adapter(options, first_iteration);
  if (options.callback) solver.callbacks.push_back(&adapter);
  ceres::Solver::Summary ceres_summary;
  ceres::Solve(solver, problem_.get(), &ceres_summary);
  if (ceres_summary.termination_type == ceres::USER_FAILURE) {
    return Interrupted(options.stage);
  }
  if (ceres_summary.termination_type == ceres::FAILURE ||
      !std::isfinite(ceres_summary.final_cost)) {
    return Status::Error(options.stage + " failed: " + ceres_summary.message);
  }
  summary->cost = ceres_summary.final_cost;
  summary->iterations = static_cast<int>(ceres_summary.iterations.size()) - 1;
  summary->converged = ceres_summary.termination_type == ceres::CONVERGENCE;
  summary->message = ceres_summary.message;
  return Status::Ok();
}

bool LeastSquaresProblem::NextActiveSet(const std::vector<bool>& fixed,
                                        const std::vector<double>& unprojected,
                                        std::vector<bool>* held,
                                        bool* another_round) {
  *another_round = false;
  const std::vector<bool> was_held = *held;
  held->assign(x_.size(), false);
  auto on_a_face = [&](size_t i) {
    return (fixed.empty() || !fixed[i]) &&
           (x_[i] == lower_[i] || x_[i] == upper_[i]);
  };
  bool any = false;
  for (size_t i = 0; i < x_.size(); ++i) any = any || on_a_face(i);
  if (!any) return true;
  // The gradient J^T f of the cost, one-sided (from inside) at the bounds;
  // the Jacobian is the one Ceres evaluated here last, or starts from (the
  // residuals cache it).
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
  if (!Evaluate(std::vector<double>(x_), nullptr, &residuals, &jacobian)) {
    return false;
  }
  const Eigen::VectorXd gradient = jacobian.transpose() * residuals;
  for (size_t i = 0; i < x_.size(); ++i) {
    if (!on_a_face(i)) continue;
    const double g = gradient(static_cast<Eigen::Index>(i));
    const bool at_lower = x_[i] == lower_[i];
    const bool at_upper = x_[i] == upper_[i];
    if (at_lower && at_upper) {  // a box of zero width
      (*held)[i] = true;
      continue;
    }
    (*held)[i] = (at_lower && g > 0) || (at_upper && g < 0);
    const bool pulled_in = (at_lower && g < 0) || (at_upper && g > 0);
    // Held, or beyond the bound (a zero column): the solve did not move it.
    const bool kept_by_the_box = was_held[i] || unprojected[i] != x_[i];
    // Free on its bound to the end: its outward steps may have stalled the
    // solve of the others.
    const bool newly_held = (*held)[i] && !was_held[i] && !kept_by_the_box;
    *another_round =
        *another_round || (pulled_in && kept_by_the_box) || newly_held;
  }
  return true;
}

bool LeastSquaresProblem::Evaluate(const std::vector<double>& x, double* cost,
                                   Eigen::VectorXd* residuals,
                                   Eigen::MatrixXd* jacobian) {
  // The residual blocks are called directly: a block's Jacobian column for
  // a parameter of size 1 is contiguous, so it is written in place into the
  // column-major dense matrix (Ceres' Evaluate would hold it twice more, as
  // its own sparse matrix and as a CRSMatrix).
  x_ = x;
  std::vector<const double*> blocks;
  for (const double& block : x_) blocks.push_back(&block);
  int rows = 0;
  for (const ceres::CostFunction* block : residual_blocks_) {
    rows += block->num_residuals();
  }
  Eigen::VectorXd r(rows);
  if (jacobian != nullptr) jacobian->resize(rows, num_parameters());
  std::vector<double*> columns(x_.size(), nullptr);
  int offset = 0;
  for (const ceres::CostFunction* block : residual_blocks_) {
    for (size_t i = 0; jacobian != nullptr && i < x_.size(); ++i) {
      columns[i] = jacobian->col(static_cast<Eigen::Index>(i)).data() + offset;
    }
    if (!block->Evaluate(blocks.data(), r.data() + offset,
                         jacobian != nullptr ? columns.data() : nullptr)) {
      return false;
    }
    offset += block->num_residuals();
  }
  if (!r.allFinite() || (jacobian != nullptr && !jacobian->allFinite())) {
    return false;
  }
  if (cost != nullptr) *cost = 0.5 * r.squaredNorm();
  if (residuals != nullptr) *residuals = std::move(r);
  return true;
}

// Within 0.1 % of a bound's own size, or of the box's width at a bound of
// zero: a stiffness scale box [0.1, 10] flags 0.1001 and 9.99 (as the
// estimator always did), an effect's [0, d] box flags 0.001 d.
bool LeastSquaresProblem::AtBound(int i, double x_i) const {
  const double width = upper_[i] - lower_[i];
  auto tolerance = [width](double bound) {
    return 1e-3 * (bound != 0 ? std::abs(bound) : width);
  };
  return x_i - lower_[i] < tolerance(lower_[i]) ||
         upper_[i] - x_i < tolerance(upper_[i]);
}

}  // namespace kcrig
