#include "rt_core/rig_plant.h"

namespace kcrig {

template class BasicRigPlant<double>;

}  // namespace kcrig
