#include "estimator/least_squares.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "ceres/ceres.h"

namespace kcrig {
namespace {

// The caller's IterationCallback as Ceres' own, which can abort the solve.
class CallbackAdapter : public ceres::IterationCallback {
 public:
  explicit CallbackAdapter(const LeastSquaresOptions& options)
      : options_(options) {}

  ceres::CallbackReturnType operator()(
      const ceres::IterationSummary& iteration) override {
    IterationSummary summary;
    summary.stage =
        options_.stage + ": iteration " + std::to_string(iteration.iteration);
    summary.done = iteration.iteration;
    summary.total = options_.max_iterations;
    return options_.callback(summary) == CallbackReturn::kAbort
               ? ceres::SOLVER_ABORT
               : ceres::SOLVER_CONTINUE;
  }

 private:
  const LeastSquaresOptions& options_;
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
  problem_->AddResidualBlock(residual, nullptr, blocks);
  residual_blocks_.push_back(residual);
}

Status LeastSquaresProblem::Minimize(const LeastSquaresOptions& options,
                                     const std::vector<bool>& fixed,
                                     std::vector<double>* x,
                                     LeastSquaresSummary* summary) {
  *summary = LeastSquaresSummary();
  x_ = *x;
  int free = 0;
  for (size_t i = 0; i < x_.size(); ++i) {
    if (!fixed.empty() && fixed[i]) {
      problem_->SetParameterBlockConstant(&x_[i]);
    } else {
      problem_->SetParameterBlockVariable(&x_[i]);
      ++free;
    }
  }
  if (free == 0) {
    if (!Evaluate(*x, &summary->cost, nullptr, nullptr)) {
      return Status::Error("the model cannot be evaluated at these parameters");
    }
    summary->converged = true;
    return Status::Ok();
  }
  ceres::Solver::Options solver;
  solver.minimizer_type = ceres::TRUST_REGION;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = options.max_iterations;
  solver.function_tolerance = options.function_tolerance;
  solver.gradient_tolerance = options.gradient_tolerance;
  solver.parameter_tolerance = options.parameter_tolerance;
  // Ceres keeps a Jacobian scratch per thread the size of the largest
  // residual block (a whole log): threads beyond the blocks only cost memory.
  solver.num_threads =
      std::max(1, std::min(options.num_threads, problem_->NumResidualBlocks()));
  solver.logging_type = ceres::SILENT;
  CallbackAdapter adapter(options);
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
  *x = x_;
  summary->cost = ceres_summary.final_cost;
  summary->iterations = static_cast<int>(ceres_summary.iterations.size()) - 1;
  summary->converged = ceres_summary.termination_type == ceres::CONVERGENCE;
  summary->message = ceres_summary.message;
  return Status::Ok();
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
