#include "rt_core/model/tangent_linear.h"

namespace kcrig {

template class SuspensionModel<Dual<double>>;

}  // namespace kcrig
