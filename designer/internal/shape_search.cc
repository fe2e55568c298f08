#include "designer/internal/shape_search.h"

#include <cmath>
#include <exception>

#include "nlopt.hpp"

namespace kcrig {
namespace {

struct Context {
  const ExperimentConfig* experiment;
  const RampShape* shape;
  const std::function<double(const RampExcitation<double>&)>* objective;
  ShapeSearchResult* result;
};

double Evaluate(const std::vector<double>& u, std::vector<double>& /*grad*/,
                void* data) {
  const Context& c = *static_cast<Context*>(data);
  const Interval& phi = c.experiment->phi_bounds;
  const Interval& z = c.experiment->z_a_bounds;
  const RampExcitation<double> ramp{phi.lower + u[0] * (phi.upper - phi.lower),
                                    z.lower + u[1] * (z.upper - z.lower),
                                    c.experiment->fmax,
                                    c.shape->tf,
                                    c.shape->hold,
                                    c.shape->return_duration};
  const double value = (*c.objective)(ramp);
  ++c.result->evaluations;
  if (!std::isfinite(value)) return 0.0;
  if (value > c.result->value) {
    c.result->value = value;
    c.result->best = ramp;
  }
  return value;
}

}  // namespace

ShapeSearchResult MaximizeOverShapes(
    const ExperimentConfig& experiment, const std::vector<RampShape>& shapes,
    int evaluations_per_shape,
    const std::function<double(const RampExcitation<double>&)>& objective) {
  ShapeSearchResult result;
  for (const RampShape& shape : shapes) {
    Context context{&experiment, &shape, &objective, &result};
    nlopt::opt opt(nlopt::LN_BOBYQA, 2);
    opt.set_lower_bounds({0.0, 0.0});
    opt.set_upper_bounds({1.0, 1.0});
    opt.set_maxeval(evaluations_per_shape);
    opt.set_xtol_abs(1e-3);
    opt.set_max_objective(Evaluate, &context);
    std::vector<double> u = {0.5, 0.5};
    double best = 0;
    try {
      opt.optimize(u, best);
    } catch (const std::exception&) {
      // A roundoff-limited or failed BOBYQA still leaves its best point in
      // `result`; nothing else to do.
    }
  }
  return result;
}

}  // namespace kcrig
