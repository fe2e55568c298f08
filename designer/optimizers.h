// The optimizers of the design problem, all behind one entry point
// (Optimize) and all working on a DesignObjective in unit coordinates:
//   imfil          implicit filtering (Kelley): projected BFGS on a
//                  central-difference stencil gradient with shrinking scales
//   kriging        DACE-style kriging surrogate, refined where its minimum
//                  or its expected improvement lies
//   nlopt:NAME     an NLopt algorithm: direct-l, crs2 (global), bobyqa,
//                  cobyla (local, derivative-free), slsqp, mma (local, with
//                  the criterion's gradient); E and MM in epigraph form
//   grid           the criterion on a regular grid over the bounds (Fig. 5)
#ifndef KCRIG_DESIGNER_OPTIMIZERS_H_
#define KCRIG_DESIGNER_OPTIMIZERS_H_

#include <string>
#include <vector>

#include "designer/design_objective.h"

namespace kcrig {

enum class KrigingRegression { kConstant, kLinear, kQuadratic };

struct OptimizerOptions {
  // Stop when the design moves less than this in unit coordinates
  // (1e-3 of the bounds: 0.09 deg, 0.5 mm) and the criterion less than
  // value_tolerance (relative) between iterations.
  double unit_tolerance = 1e-3;
  double value_tolerance = 1e-6;

  // imfil: stencil scales h = initial_scale * 2^-k, k = 0 .. num_scales - 1,
  // in unit coordinates; at most max_armijo halvings of a quasi-Newton step.
  double imfil_initial_scale = 0.25;
  int imfil_num_scales = 8;
  int imfil_max_armijo = 4;

  // kriging: initial Latin-hypercube design (plus the start), regression
  // trend, and whether each refinement also adds the maximizer of the
  // expected improvement (keeps the search global; uses the second core).
  int kriging_initial_points = 12;
  KrigingRegression kriging_regression = KrigingRegression::kQuadratic;
  bool kriging_expected_improvement = true;
  unsigned kriging_seed = 1;

  // grid: points along phi and along z_a, bounds included.
  int grid_phi_points = 46;  // 2 deg over 0..90 deg
  int grid_z_points = 26;    // 0.02 m over -0.5..0 m
};

struct OptimizationResult {
  std::string optimizer;
  Design start;
  double start_value = 0;
  Design best;
  double best_value = 0;
  bool best_singular = false;
  int evaluations = 0;  // criterion evaluations spent
  double seconds = 0;   // wall time
  bool budget_exhausted = false;
  std::string message;       // why it stopped
  std::vector<Design> path;  // accepted iterates, start first
};

// Names accepted by Optimize, for help texts and errors.
const std::vector<std::string>& OptimizerNames();

// An error naming the accepted optimizers unless `optimizer` is one.
Status ValidateOptimizerName(const std::string& optimizer);

// Minimizes the objective's criterion from `start` (inside the bounds)
// within the objective's budget. The start is evaluated first. Fills
// `result` from the objective's record (the best evaluation seen);
// Interrupted() when the objective's callback stopped the search.
Status Optimize(const std::string& optimizer, DesignObjective* objective,
                const Design& start, const OptimizerOptions& options,
                OptimizationResult* result);

// The individual algorithms; each has the contract of Optimize.
Status GridSearch(DesignObjective* objective, const OptimizerOptions& options,
                  OptimizationResult* result);
Status ImplicitFiltering(DesignObjective* objective,
                         const OptimizerOptions& options,
                         OptimizationResult* result);
Status KrigingSearch(DesignObjective* objective,
                     const OptimizerOptions& options,
                     OptimizationResult* result);
Status NloptSearch(const std::string& algorithm, DesignObjective* objective,
                   const OptimizerOptions& options, OptimizationResult* result);

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_OPTIMIZERS_H_
