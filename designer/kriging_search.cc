// Surrogate optimization with a kriging model (the paper's DACE+SNOPT,
// after Hemker): a Latin-hypercube initial design, then per iteration a
// fresh fit to every evaluation so far, the true criterion at the
// surrogate's minimum and, on the second core, at the maximizer of the
// expected improvement, until the surrogate minimum stops moving or the
// budget is spent. The surrogate's extrema are found on a lattice and
// polished with BOBYQA (the surrogate is cheap and infinitely smooth).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

#include "designer/kriging.h"
#include "designer/optimizers.h"
#include "nlopt.hpp"

namespace kcrig {
namespace {

constexpr int kLattice = 41;         // points per axis for the extrema
constexpr int kStallIterations = 4;  // no progress this long: stop

std::vector<Eigen::Vector2d> LatinHypercube(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(0.0, 1.0);
  std::vector<int> a(n), b(n);
  std::iota(a.begin(), a.end(), 0);
  std::iota(b.begin(), b.end(), 0);
  std::shuffle(b.begin(), b.end(), rng);
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < n; ++i) {
    points.emplace_back((a[i] + jitter(rng)) / n, (b[i] + jitter(rng)) / n);
  }
  return points;
}

// argmin over the box of `f` (cheap): lattice, then BOBYQA from the best.
template <typename F>
Eigen::Vector2d MinimizeCheap(const F& f) {
  Eigen::Vector2d best(0, 0);
  double best_value = std::numeric_limits<double>::infinity();
  for (int i = 0; i < kLattice; ++i) {
    for (int j = 0; j < kLattice; ++j) {
      const Eigen::Vector2d u(i / (kLattice - 1.0), j / (kLattice - 1.0));
      const double v = f(u);
      if (v < best_value) {
        best_value = v;
        best = u;
      }
    }
  }
  nlopt::opt opt(nlopt::LN_BOBYQA, 2);
  opt.set_lower_bounds({0, 0});
  opt.set_upper_bounds({1, 1});
  auto trampoline = [](unsigned, const double* x, double*, void* data) {
    return (*static_cast<const F*>(data))(Eigen::Vector2d(x[0], x[1]));
  };
  opt.set_min_objective(trampoline, const_cast<F*>(&f));
  opt.set_initial_step(0.5 / (kLattice - 1));
  opt.set_xtol_abs(1e-6);
  opt.set_maxeval(200);
  std::vector<double> x = {best(0), best(1)};
  double value = best_value;
  try {
    opt.optimize(x, value);
  } catch (const std::exception&) {
    return best;
  }
  return value < best_value ? Eigen::Vector2d(x[0], x[1]) : best;
}

double DistanceToData(const Eigen::Vector2d& u,
                      const std::vector<DesignEvaluation>& record) {
  double d = std::numeric_limits<double>::infinity();
  for (const DesignEvaluation& e : record) d = std::min(d, (e.unit - u).norm());
  return d;
}

}  // namespace

Status KrigingSearch(DesignObjective* objective,
                     const OptimizerOptions& options,
                     OptimizationResult* result) {
  KrigingOptions kriging_options;
  kriging_options.regression = options.kriging_regression;
  const int terms =
      options.kriging_regression == KrigingRegression::kQuadratic ? 6
      : options.kriging_regression == KrigingRegression::kLinear  ? 3
                                                                  : 1;
  if (options.kriging_initial_points < terms) {
    return Status::Error("kriging: the initial design needs at least " +
                         std::to_string(terms) + " points for the regression");
  }
  const Criterion criterion = objective->criterion();
  objective->Evaluate(
      LatinHypercube(options.kriging_initial_points, options.kriging_seed));

  KrigingModel model;
  Eigen::Vector2d theta(1, 1);
  bool have_theta = false;
  double best_so_far = std::numeric_limits<double>::infinity();
  int stalled = 0;
  // Points closer than this to an evaluated one add nothing: the surrogate
  // interpolates there already.
  const double resolution = 0.5 * options.unit_tolerance;
  while (objective->remaining() > 0) {
    std::vector<Eigen::Vector2d> x;
    std::vector<double> y;
    for (const DesignEvaluation& e : objective->record()) {
      x.push_back(e.unit);
      y.push_back(OptimizationScale(criterion, e.value));
    }
    const Status fit =
        model.Fit(x, y, kriging_options, have_theta ? &theta : nullptr);
    if (!fit.ok()) return fit;
    theta = model.theta();
    have_theta = true;
    const DesignEvaluation& best = objective->best();
    const double best_value = OptimizationScale(criterion, best.value);

    std::vector<Eigen::Vector2d> candidates;
    const Eigen::Vector2d surrogate_min = MinimizeCheap(
        [&model](const Eigen::Vector2d& u) { return model.Predict(u); });
    const bool minimum_known =
        DistanceToData(surrogate_min, objective->record()) < resolution;
    if (!minimum_known) candidates.push_back(surrogate_min);
    if (options.kriging_expected_improvement) {
      const auto negative_ei = [&model, best_value](const Eigen::Vector2d& u) {
        double mse = 0;
        const double prediction = model.Predict(u, &mse);
        return -ExpectedImprovement(best_value, prediction, mse);
      };
      const Eigen::Vector2d ei_max = MinimizeCheap(negative_ei);
      if (-negative_ei(ei_max) > options.value_tolerance &&
          DistanceToData(ei_max, objective->record()) >= resolution &&
          (candidates.empty() ||
           (ei_max - candidates[0]).norm() >= resolution)) {
        candidates.push_back(ei_max);
      }
    }
    if (candidates.empty()) {
      result->message =
          "surrogate minimum at an evaluated point, no expected "
          "improvement left";
      return Status::Ok();
    }
    objective->Evaluate(candidates);
    result->path.push_back(objective->best().design);

    const double now = OptimizationScale(criterion, objective->best().value);
    stalled = now < best_so_far - options.value_tolerance ? 0 : stalled + 1;
    best_so_far = std::min(best_so_far, now);
    if (stalled >= kStallIterations && minimum_known) {
      result->message = "surrogate minimum converged";
      return Status::Ok();
    }
  }
  result->message = "budget exhausted";
  return Status::Ok();
}

}  // namespace kcrig
