// Implicit filtering (C. T. Kelley, "Implicit Filtering", SIAM 2011):
// a projected quasi-Newton method whose gradient comes from a
// central-difference stencil of scale h in the unit box; when the centre is
// better than every stencil point (stencil failure) or the stencil gradient
// is small against h, the scale is halved. Like Kelley's imfil with an
// explore function, the first iteration also evaluates a coarse lattice
// over the box and moves to its best point, so that the local search starts
// in the best basin rather than the nearest one.
#include <cmath>
#include <vector>

#include "Eigen/Dense"
#include "designer/internal/stencil.h"
#include "designer/optimizers.h"

namespace kcrig {
namespace {

constexpr double kArmijo = 1e-4;       // sufficient-decrease constant
constexpr double kBoundSlack = 1e-12;  // "on the bound" in unit coordinates
constexpr int kMaxIterationsPerScale = 20;
constexpr int kExplorePerAxis = 4;  // 4 x 4 lattice of cell centres

struct Point {
  Eigen::Vector2d u;
  double f = 0;  // OptimizationScale of the criterion
};

Eigen::Vector2d Project(const Eigen::Vector2d& u) {
  return u.cwiseMax(0.0).cwiseMin(1.0);
}

// The criterion on the optimizer's scale (smaller is better).
class ScaledCriterion {
 public:
  explicit ScaledCriterion(Criterion criterion) : criterion_(criterion) {}
  double operator()(const DesignEvaluation& e) const {
    return OptimizationScale(criterion_, e.value);
  }

 private:
  Criterion criterion_;
};

// The exploration: a coarse lattice over the box, *x moved to its best
// point. False when the budget ran out.
bool Explore(DesignObjective* objective, const ScaledCriterion& scaled,
             Point* x) {
  std::vector<Eigen::Vector2d> lattice;
  for (int i = 0; i < kExplorePerAxis; ++i) {
    for (int j = 0; j < kExplorePerAxis; ++j) {
      lattice.emplace_back((i + 0.5) / kExplorePerAxis,
                           (j + 0.5) / kExplorePerAxis);
    }
  }
  const std::vector<DesignEvaluation> explored = objective->Evaluate(lattice);
  for (const DesignEvaluation& e : explored) {
    if (scaled(e) < x->f) *x = {e.unit, scaled(e)};
  }
  return explored.size() == lattice.size();
}

// The BFGS update of the Hessian model by the step s and gradient change y
// (skipped without positive curvature; the first one scales the identity).
void UpdateHessian(const Eigen::Vector2d& s, const Eigen::Vector2d& y,
                   Eigen::Matrix2d* hessian, bool* hessian_scaled) {
  const double ys = y.dot(s);
  if (!(ys > 1e-10 * y.norm() * s.norm())) return;
  if (!*hessian_scaled) {
    *hessian = Eigen::Matrix2d::Identity() * (y.dot(y) / ys);
    *hessian_scaled = true;
  }
  const Eigen::Vector2d hs = *hessian * s;
  *hessian += y * y.transpose() / ys - hs * hs.transpose() / s.dot(hs);
}

// The projected quasi-Newton direction: variables on a bound with the
// gradient pushing outwards are held; the rest use the reduced model. A
// direction that is no descent restarts the Hessian model.
Eigen::Vector2d ProjectedDirection(const Eigen::Vector2d& u,
                                   const Eigen::Vector2d& gradient,
                                   Eigen::Matrix2d* hessian,
                                   bool* hessian_scaled) {
  Eigen::Matrix2d reduced = *hessian;
  Eigen::Vector2d reduced_gradient = gradient;
  for (int i = 0; i < 2; ++i) {
    const bool active = (u(i) <= kBoundSlack && gradient(i) > 0) ||
                        (u(i) >= 1 - kBoundSlack && gradient(i) < 0);
    if (!active) continue;
    reduced.row(i).setZero();
    reduced.col(i).setZero();
    reduced(i, i) = 1;
    reduced_gradient(i) = 0;
  }
  Eigen::Vector2d direction = -reduced.ldlt().solve(reduced_gradient);
  if (!direction.allFinite() || direction.dot(reduced_gradient) >= 0) {
    *hessian = Eigen::Matrix2d::Identity();  // lost curvature: restart
    *hessian_scaled = false;
    direction = -reduced_gradient;
  }
  return direction;
}

// Armijo on the projected path from x, two step lengths per batch: the
// first point of sufficient decrease in *candidate. False when the budget
// ran out before one was found.
bool ArmijoSearch(DesignObjective* objective, const OptimizerOptions& options,
                  const ScaledCriterion& scaled, const Point& x,
                  const Eigen::Vector2d& gradient,
                  const Eigen::Vector2d& direction, Point* candidate,
                  bool* accepted) {
  *accepted = false;
  for (int tried = 0; tried < options.imfil_max_armijo && !*accepted;
       tried += 2) {
    std::vector<Eigen::Vector2d> trials;
    for (int t = tried; t < tried + 2 && t < options.imfil_max_armijo; ++t) {
      trials.push_back(Project(x.u + std::ldexp(1.0, -t) * direction));
    }
    const std::vector<DesignEvaluation> tried_values =
        objective->Evaluate(trials);
    for (const DesignEvaluation& e : tried_values) {
      const double decrease = kArmijo * gradient.dot(x.u - e.unit);
      if (e.unit != x.u && scaled(e) <= x.f - decrease) {
        *candidate = {e.unit, scaled(e)};
        *accepted = true;
        break;
      }
    }
    if (tried_values.size() < trials.size() && !*accepted) return false;
  }
  return true;
}

}  // namespace

Status ImplicitFiltering(DesignObjective* objective,
                         const OptimizerOptions& options,
                         OptimizationResult* result) {
  if (!(options.imfil_initial_scale > 0) || options.imfil_num_scales < 1) {
    return Status::Error("imfil: initial scale must be > 0, scales >= 1");
  }
  const ScaledCriterion scaled(objective->criterion());
  const DesignEvaluation& start = objective->record().front();
  Point x{start.unit, scaled(start)};
  auto out_of_budget = [&](const char* where) {
    result->message = std::string("budget exhausted (") + where + ")";
    return Status::Ok();
  };
  if (!Explore(objective, scaled, &x)) return out_of_budget("exploration");
  result->path.push_back(objective->ToDesign(x.u));

  Eigen::Matrix2d hessian = Eigen::Matrix2d::Identity();
  bool hessian_scaled = false;
  for (int k = 0; k < options.imfil_num_scales; ++k) {
    const double h = options.imfil_initial_scale * std::ldexp(1.0, -k);
    bool have_previous = false;
    Eigen::Vector2d previous_u = x.u,
                    previous_gradient = Eigen::Vector2d::Zero();
    for (int iteration = 0; iteration < kMaxIterationsPerScale; ++iteration) {
      const Stencil stencil(x.u, h);
      const std::vector<DesignEvaluation> values =
          objective->Evaluate(stencil.points());
      if (values.size() < stencil.points().size()) {
        return out_of_budget("stencil");
      }
      Point best_stencil = x;
      for (const DesignEvaluation& e : values) {
        if (scaled(e) < best_stencil.f) best_stencil = {e.unit, scaled(e)};
      }
      const Eigen::Vector2d gradient = stencil.Gradient(x.f, values, scaled);
      // Stencil failure: the centre beats its whole stencil at this scale.
      if (best_stencil.f >= x.f) break;
      if (have_previous) {
        UpdateHessian(x.u - previous_u, gradient - previous_gradient, &hessian,
                      &hessian_scaled);
      }
      const Eigen::Vector2d direction =
          ProjectedDirection(x.u, gradient, &hessian, &hessian_scaled);
      Point candidate = x;
      bool accepted = false;
      if (!ArmijoSearch(objective, options, scaled, x, gradient, direction,
                        &candidate, &accepted)) {
        return out_of_budget("line search");
      }
      // The best stencil point wins over a worse line-search point (and
      // replaces a failed line search).
      if (!accepted || best_stencil.f < candidate.f) candidate = best_stencil;
      previous_u = x.u;
      previous_gradient = gradient;
      have_previous = accepted;
      x = candidate;
      result->path.push_back(objective->ToDesign(x.u));
      if (objective->remaining() <= 0) return out_of_budget("iteration");
    }
  }
  result->message = "smallest stencil scale reached";
  return Status::Ok();
}

}  // namespace kcrig
