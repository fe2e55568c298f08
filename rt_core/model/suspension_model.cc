#include "rt_core/model/suspension_model.h"

namespace kcrig {

template class SuspensionModel<double>;

}  // namespace kcrig
