// The search shared by the designs that tell models or faults apart: over
// (phi, z_a) within the experiment's design bounds, for each ramp shape.
#ifndef KCRIG_DESIGNER_INTERNAL_SHAPE_SEARCH_H_
#define KCRIG_DESIGNER_INTERNAL_SHAPE_SEARCH_H_

#include <functional>
#include <vector>

#include "designer/discrimination.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

struct ShapeSearchResult {
  RampExcitation<double> best;
  double value = -1;  // -1: no evaluation succeeded
  int evaluations = 0;
};

// Maximizes `objective` (a value >= 0, or NaN where the design cannot be
// evaluated) with NLopt's BOBYQA in unit coordinates over the design
// bounds of `experiment`, from the box's centre, `evaluations_per_shape`
// evaluations for each of `shapes`, with the experiment's Fmax.
ShapeSearchResult MaximizeOverShapes(
    const ExperimentConfig& experiment, const std::vector<RampShape>& shapes,
    int evaluations_per_shape,
    const std::function<double(const RampExcitation<double>&)>& objective);

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_INTERNAL_SHAPE_SEARCH_H_
