// The criteria of one design step over a grid of the design box, as its
// optimizer searched them: the same evaluator (the step's parameter values,
// the information of its data as the prior), bounds and unit coordinates as
// DesignStep, rebuilt from what the step stored (est.json). A plot of it is
// the landscape the optimizer saw.
#ifndef KCRIG_DESIGNER_CRITERION_SURFACE_H_
#define KCRIG_DESIGNER_CRITERION_SURFACE_H_

#include <vector>

#include "base/status.h"
#include "designer/criteria.h"
#include "designer/design_step.h"
#include "designer/information.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

struct SurfaceOptions {
  // Grid points along phi and along z_a over the design bounds, bounds
  // included; at least 2 each. Each point costs one trajectory with
  // sensitivities; every criterion comes from its one information matrix.
  int phi_points = 19;
  int z_points = 11;
  // Designs evaluated besides the grid, e.g. the step's optimum, whose value
  // the grid would only interpolate.
  std::vector<Design> points;
};

struct CriterionSurface {
  std::vector<Criterion> criteria;
  std::vector<double> phi;  // [rad], the grid along phi
  std::vector<double> z_a;  // [m], the grid along z_a
  // grid[c][j * phi.size() + i]: criteria[c] at (phi[i], z_a[j]).
  std::vector<std::vector<double>> grid;
  // at_points[c][k]: criteria[c] at options.points[k].
  std::vector<std::vector<double>> at_points;
};

// `step`: the design step as DesignStep took it (names, values,
// prior_information; objective.num_threads threads; its criterion, optimizer
// and budget are not used). A design whose simulation diverges is valued as
// the optimizer valued it: no information (criteria.h).
Status ComputeCriterionSurface(const KcrigConfig& config,
                               const DesignStepOptions& step,
                               const std::vector<Criterion>& criteria,
                               const SurfaceOptions& options,
                               CriterionSurface* surface);

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_CRITERION_SURFACE_H_
