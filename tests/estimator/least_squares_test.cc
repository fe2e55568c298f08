// The projected Levenberg-Marquardt of LeastSquaresProblem on small
// analytic problems whose solutions are known: a bound the data push
// against, a start on a bound, a parameter pushed beyond its bound early
// and pulled back in later, and the box itself never left.
#include "estimator/internal/least_squares.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <utility>
#include <vector>

#include "ceres/cost_function.h"

namespace kcrig {
namespace {

// Residuals f(x) of two parameters (blocks of size 1) given with their
// Jacobian; records every point it is evaluated at.
class TwoParameterResidual : public ceres::CostFunction {
 public:
  using Function =
      std::function<void(double, double, double* f, double* d0, double* d1)>;
  TwoParameterResidual(int num_residuals, Function f,
                       std::vector<std::vector<double>>* visited)
      : f_(std::move(f)), visited_(visited) {
    mutable_parameter_block_sizes()->assign(2, 1);
    set_num_residuals(num_residuals);
  }
  bool Evaluate(double const* const* x, double* residuals,
                double** jacobians) const override {
    visited_->push_back({x[0][0], x[1][0]});
    std::vector<double> d0(num_residuals()), d1(num_residuals());
    f_(x[0][0], x[1][0], residuals, d0.data(), d1.data());
    if (jacobians != nullptr) {
      for (int r = 0; r < num_residuals(); ++r) {
        if (jacobians[0] != nullptr) jacobians[0][r] = d0[r];
        if (jacobians[1] != nullptr) jacobians[1][r] = d1[r];
      }
    }
    return true;
  }

 private:
  Function f_;
  std::vector<std::vector<double>>* visited_;
};

struct Fit {
  std::vector<double> x;
  LeastSquaresSummary summary;
  std::vector<std::vector<double>> visited;
  bool at_bound[2];
};

Fit Solve(int num_residuals, TwoParameterResidual::Function f,
          std::vector<double> start, std::vector<double> lower,
          std::vector<double> upper) {
  Fit fit;
  LeastSquaresProblem problem(lower, upper);
  problem.AddResidualBlock(
      new TwoParameterResidual(num_residuals, std::move(f), &fit.visited));
  fit.x = std::move(start);
  LeastSquaresOptions options;
  EXPECT_TRUE(problem.Minimize(options, {}, &fit.x, &fit.summary).ok());
  for (int i = 0; i < 2; ++i) fit.at_bound[i] = problem.AtBound(i, fit.x[i]);
  for (const std::vector<double>& x : fit.visited) {
    for (int i = 0; i < 2; ++i) {
      EXPECT_GE(x[i], lower[i]);
      EXPECT_LE(x[i], upper[i]);
    }
  }
  return fit;
}

// Writes two residuals f and their derivatives d0 (by x0), d1 (by x1).
void Set(double* f, double* d0, double* d1, std::array<double, 2> f_value,
         std::array<double, 2> d0_value, std::array<double, 2> d1_value) {
  for (int r = 0; r < 2; ++r) {
    f[r] = f_value[r];
    d0[r] = d0_value[r];
    d1[r] = d1_value[r];
  }
}

// f = (x0 + 1, x1 - 2 + 0.5 x0): the unconstrained optimum (-1, 2.5) lies
// beyond x0 >= 0; on the bound the best x1 is 2.
void Linear(double x0, double x1, double* f, double* d0, double* d1) {
  Set(f, d0, d1, {x0 + 1, x1 - 2 + 0.5 * x0}, {1, 0.5}, {0, 1});
}

TEST(LeastSquaresProblemTest, EndsOnTheBoundTheDataPushAgainst) {
  const Fit fit = Solve(2, Linear, {3, 0}, {0, -10}, {10, 10});
  EXPECT_EQ(fit.x[0], 0.0);
  EXPECT_NEAR(fit.x[1], 2.0, 1e-9);
  EXPECT_TRUE(fit.at_bound[0]);
  EXPECT_FALSE(fit.at_bound[1]);
  EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
  // Projected steps: no crawl towards the bound.
  EXPECT_LE(fit.summary.iterations, 6);
}

TEST(LeastSquaresProblemTest, AStartOnABoundPushedOutwardStillFitsTheRest) {
  // Every step pushes x0 below its bound: a rejected whole step would
  // leave x1 at its start.
  const Fit fit = Solve(2, Linear, {0, -5}, {0, -10}, {10, 10});
  EXPECT_EQ(fit.x[0], 0.0);
  EXPECT_NEAR(fit.x[1], 2.0, 1e-9);
  EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
}

TEST(LeastSquaresProblemTest,
     AStartOnABoundWithTheRestNearlyFittedDoesNotStall) {
  // x1 is 0.01 from its optimum: a free x0 pushed outward on every step
  // would leave almost no decrease the model predicts, and Ceres would
  // call the start converged.
  const Fit fit = Solve(2, Linear, {0, 1.99}, {0, -10}, {10, 10});
  EXPECT_EQ(fit.x[0], 0.0);
  EXPECT_NEAR(fit.x[1], 2.0, 1e-5);  // a stall leaves 1.99
  EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
}

// f = (x0 - 1, x1 - 2 + 0.5 x0): the optimum (1, 1.5) lies beyond x0 <= 0;
// on the bound the best x1 is 2.
void BeyondTheUpperBound(double x0, double x1, double* f, double* d0,
                         double* d1) {
  Linear(x0 - 2, x1 + 1, f, d0, d1);
}

TEST(LeastSquaresProblemTest, EndsOnAnUpperBoundTheDataPushAgainst) {
  for (const std::vector<double>& start :
       {std::vector<double>{-3, 0}, {0, 1.99}}) {
    const Fit fit = Solve(2, BeyondTheUpperBound, start, {-10, -10}, {0, 10});
    EXPECT_EQ(fit.x[0], 0.0);
    EXPECT_NEAR(fit.x[1], 2.0, 1e-5);
    EXPECT_TRUE(fit.at_bound[0]);
    EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
  }
}

// f = (x0 + 1 - x1, 10 (x1 - 2)): optimum (1, 2) inside the box. From
// (0, 0) the data push x0 below its bound, so it is held; once x1 has
// moved, they pull it back in and the next round frees it.
void HeldThenReleased(double x0, double x1, double* f, double* d0, double* d1) {
  Set(f, d0, d1, {x0 + 1 - x1, 10 * (x1 - 2)}, {1, 0}, {-1, 10});
}

TEST(LeastSquaresProblemTest, AHeldParameterIsReleasedWhenPulledBackIn) {
  const Fit fit = Solve(2, HeldThenReleased, {0, 0}, {0, -10}, {10, 10});
  // Held first: x1 moved while x0 stayed on its bound (free, one
  // Gauss-Newton step would have gone straight to the optimum).
  bool held_first = false;
  for (const std::vector<double>& x : fit.visited) {
    held_first = held_first || (x[0] == 0.0 && x[1] > 0.5);
  }
  EXPECT_TRUE(held_first);
  EXPECT_NEAR(fit.x[0], 1.0, 1e-9);
  EXPECT_NEAR(fit.x[1], 2.0, 1e-9);
  EXPECT_FALSE(fit.at_bound[0]);
  EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
}

// f = (x0 - x1^2, 10 (x1 - 1)): optimum (1, 1) inside the box. From
// (5, 3) the Gauss-Newton step sends x0 to 2*3 - 9 = -3, beyond x0 >= 0;
// once x1 has settled, the data pull x0 back in.
void Curved(double x0, double x1, double* f, double* d0, double* d1) {
  Set(f, d0, d1, {x0 - x1 * x1, 10 * (x1 - 1)}, {1, 0}, {-2 * x1, 10});
}

TEST(LeastSquaresProblemTest, AParameterPushedOutEarlyIsReleased) {
  const Fit fit = Solve(2, Curved, {5, 3}, {0, -10}, {10, 10});
  EXPECT_NEAR(fit.x[0], 1.0, 1e-7);
  EXPECT_NEAR(fit.x[1], 1.0, 1e-7);
  EXPECT_FALSE(fit.at_bound[0]);
  EXPECT_NEAR(fit.summary.cost, 0.0, 1e-12);
  EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
  // It did touch the bound on the way (else this test shows nothing).
  bool touched = false;
  for (const std::vector<double>& x : fit.visited) {
    touched = touched || x[0] == 0.0;
  }
  EXPECT_TRUE(touched);
}

TEST(LeastSquaresProblemTest, EvaluateProjectsAndZeroesColumnsBeyondTheBox) {
  std::vector<std::vector<double>> visited;
  LeastSquaresProblem problem({0, -10}, {10, 10});
  problem.AddResidualBlock(new TwoParameterResidual(2, Linear, &visited));
  double cost = 0;
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
  ASSERT_TRUE(problem.Evaluate({-4, 1}, &cost, &residuals, &jacobian));
  EXPECT_EQ(visited.back()[0], 0.0);
  EXPECT_DOUBLE_EQ(residuals(0), 1.0);  // at x0 = 0, not -4
  EXPECT_EQ(jacobian(0, 0), 0.0);
  EXPECT_EQ(jacobian(1, 0), 0.0);
  EXPECT_EQ(jacobian(1, 1), 1.0);
  EXPECT_FALSE(problem.Evaluate({std::nan(""), 1}, &cost, nullptr, nullptr));
}

}  // namespace
}  // namespace kcrig
