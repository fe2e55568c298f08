// The scalar every exact-sensitivity fit steps in (the estimator's
// trajectories, the diagnosis' single effects): a Jet of 8 directions, its
// tangent-linear model and plant compiled once (sensitivity_plant.cc)
// instead of in each file that fits.
#ifndef KCRIG_ESTIMATOR_INTERNAL_SENSITIVITY_PLANT_H_
#define KCRIG_ESTIMATOR_INTERNAL_SENSITIVITY_PLANT_H_

#include "ceres/jet.h"
#include "rt_core/model/rig_plant.h"
#include "rt_core/model/suspension_model.h"
#include "rt_core/model/tangent_linear.h"

namespace kcrig {

using SensitivityJet = ceres::Jet<double, 8>;

extern template class SuspensionModel<SensitivityJet>;
extern template class TangentLinearModel<SensitivityJet>;
extern template class BasicRigPlant<SensitivityJet>;

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_INTERNAL_SENSITIVITY_PLANT_H_
