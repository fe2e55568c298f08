#include "estimator/internal/sensitivity_plant.h"

namespace kcrig {

template class SuspensionModel<SensitivityJet>;
template class TangentLinearModel<SensitivityJet>;
template class BasicRigPlant<SensitivityJet>;

}  // namespace kcrig
