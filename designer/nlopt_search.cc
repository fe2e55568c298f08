// NLopt drivers for the design problem, in unit coordinates.
//   direct-l, crs2   global search over the box with half the budget, then
//                    BOBYQA from its best point with the rest
//   bobyqa, cobyla   local, derivative-free
//   slsqp, mma       local, with the gradient of the criterion by central
//                    differences (step 1e-4 of the box): the exact-
//                    sensitivity criterion is smooth to ~1e-13 relative
//                    (ecnoise), so these gradients carry ~8 digits
// E and MM with cobyla, slsqp or mma are solved in epigraph form,
//   min t  s.t.  ln g_k(v) - t <= 0,  g_k from CriterionValue::epigraph,
// which has smooth constraints where the criterion itself has kinks. The
// other algorithms take E and MM as they are.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "designer/internal/stencil.h"
#include "designer/optimizers.h"
#include "nlopt.hpp"

namespace kcrig {
namespace {

constexpr double kGradientStep = 1e-4;

struct Context {
  DesignObjective* objective;
  bool epigraph = false;
};

double Scaled(const DesignObjective& objective, const DesignEvaluation& e) {
  return OptimizationScale(objective.criterion(), e.value);
}

// The evaluation at u and, when `gradient_wanted`, its stencil (one batch).
struct Evaluated {
  DesignEvaluation centre;
  std::vector<DesignEvaluation> stencil_values;
};

Evaluated EvaluateWithStencil(DesignObjective* objective, const Stencil& s,
                              const Eigen::Vector2d& u, bool gradient_wanted) {
  std::vector<Eigen::Vector2d> points = {u};
  if (gradient_wanted) {
    points.insert(points.end(), s.points().begin(), s.points().end());
  }
  std::vector<DesignEvaluation> values = objective->Evaluate(points);
  if (values.size() < points.size()) throw nlopt::forced_stop();
  Evaluated e{values.front(), {}};
  e.stencil_values.assign(values.begin() + 1, values.end());
  return e;
}

double Objective(unsigned n, const double* x, double* grad, void* data) {
  Context* c = static_cast<Context*>(data);
  if (c->epigraph) {  // min t
    if (grad) {
      for (unsigned i = 0; i < n; ++i) grad[i] = i == n - 1 ? 1 : 0;
    }
    return x[n - 1];
  }
  const Eigen::Vector2d u(x[0], x[1]);
  const Stencil stencil(u, kGradientStep);
  const Evaluated evaluated =
      EvaluateWithStencil(c->objective, stencil, u, grad != nullptr);
  const auto f = [c](const DesignEvaluation& e) {
    return Scaled(*c->objective, e);
  };
  if (grad) {
    const Eigen::Vector2d gradient =
        stencil.Gradient(f(evaluated.centre), evaluated.stencil_values, f);
    grad[0] = gradient(0);
    grad[1] = gradient(1);
  }
  return f(evaluated.centre);
}

// c_k = ln g_k(u) - t, gradient rows of length 3.
void EpigraphConstraints(unsigned m, double* result, unsigned n,
                         const double* x, double* grad, void* data) {
  Context* c = static_cast<Context*>(data);
  const Eigen::Vector2d u(x[0], x[1]);
  const Stencil stencil(u, kGradientStep);
  const Evaluated evaluated =
      EvaluateWithStencil(c->objective, stencil, u, grad != nullptr);
  for (unsigned k = 0; k < m; ++k) {
    const auto g = [k](const DesignEvaluation& e) {
      return std::log(e.epigraph[k]);
    };
    result[k] = g(evaluated.centre) - x[2];
    if (grad) {
      const Eigen::Vector2d gradient =
          stencil.Gradient(g(evaluated.centre), evaluated.stencil_values, g);
      grad[k * n + 0] = gradient(0);
      grad[k * n + 1] = gradient(1);
      grad[k * n + 2] = -1;
    }
  }
}

Status RunLocal(nlopt::algorithm algorithm, DesignObjective* objective,
                const Eigen::Vector2d& from, const OptimizerOptions& options,
                std::string* message) {
  if (objective->remaining() <= 0) {
    *message = "budget exhausted";
    return Status::Ok();
  }
  const Criterion criterion = objective->criterion();
  const bool epigraph =
      IsMaxType(criterion) &&
      (algorithm == nlopt::LN_COBYLA || algorithm == nlopt::LD_SLSQP ||
       algorithm == nlopt::LD_MMA);
  Context context{objective, epigraph};
  const unsigned n = epigraph ? 3 : 2;
  nlopt::opt opt(algorithm, n);
  std::vector<double> lower = {0, 0}, upper = {1, 1}, x = {from(0), from(1)};
  std::vector<double> step = {0.05, 0.05};
  if (epigraph) {
    const DesignEvaluation e = objective->Evaluate({from}).front();
    double t = -std::numeric_limits<double>::infinity();
    for (double g : e.epigraph) t = std::max(t, std::log(g));
    x.push_back(t + 1e-9);  // feasible start
    lower.push_back(t - 50);
    upper.push_back(t + 50);
    step.push_back(0.1);
    const unsigned m = static_cast<unsigned>(e.epigraph.size());
    opt.add_inequality_mconstraint(EpigraphConstraints, &context,
                                   std::vector<double>(m, 1e-9));
  }
  opt.set_lower_bounds(lower);
  opt.set_upper_bounds(upper);
  opt.set_min_objective(Objective, &context);
  opt.set_initial_step(step);
  opt.set_xtol_abs(options.unit_tolerance * 0.1);
  opt.set_ftol_abs(options.value_tolerance);
  opt.set_maxeval(objective->remaining());
  double value = 0;
  try {
    const nlopt::result r = opt.optimize(x, value);
    *message = std::string(opt.get_algorithm_name()) +
               (epigraph ? " (epigraph form)" : "") + ": " +
               (r == nlopt::XTOL_REACHED   ? "design converged"
                : r == nlopt::FTOL_REACHED ? "criterion converged"
                : r == nlopt::MAXEVAL_REACHED
                    ? "iteration limit"
                    : "stopped (code " + std::to_string(r) + ")");
  } catch (const nlopt::forced_stop&) {
    *message = "budget exhausted";
  } catch (const std::exception& e) {
    // Roundoff-limited and similar: the record holds the best point.
    *message = std::string("NLopt stopped: ") + e.what();
  }
  return Status::Ok();
}

}  // namespace

Status NloptSearch(const std::string& algorithm, DesignObjective* objective,
                   const OptimizerOptions& options,
                   OptimizationResult* result) {
  const Eigen::Vector2d start = objective->record().front().unit;
  if (algorithm == "bobyqa") {
    return RunLocal(nlopt::LN_BOBYQA, objective, start, options,
                    &result->message);
  }
  if (algorithm == "cobyla") {
    return RunLocal(nlopt::LN_COBYLA, objective, start, options,
                    &result->message);
  }
  if (algorithm == "slsqp") {
    return RunLocal(nlopt::LD_SLSQP, objective, start, options,
                    &result->message);
  }
  if (algorithm == "mma") {
    return RunLocal(nlopt::LD_MMA, objective, start, options, &result->message);
  }
  // Global phase with half the budget, then a local polish.
  Context context{objective, false};
  nlopt::opt opt(algorithm == "crs2" ? nlopt::GN_CRS2_LM : nlopt::GN_DIRECT_L,
                 2);
  opt.set_lower_bounds({0, 0});
  opt.set_upper_bounds({1, 1});
  opt.set_min_objective(Objective, &context);
  opt.set_maxeval(std::max(1, objective->remaining() / 2));
  std::vector<double> x = {start(0), start(1)};
  double value = 0;
  try {
    opt.optimize(x, value);
  } catch (const std::exception&) {
    // Budget or iteration limit: the polish starts from the best point.
  }
  std::string polish;
  Status status = RunLocal(nlopt::LN_BOBYQA, objective, objective->best().unit,
                           options, &polish);
  result->message = std::string(opt.get_algorithm_name()) + ", then " + polish;
  return status;
}

}  // namespace kcrig
