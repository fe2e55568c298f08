#include "rt_core/model/rig_plant.h"

namespace kcrig {

template class BasicRigPlant<double>;

}  // namespace kcrig
