#include "rt_core/model/suspension_parameters.h"

namespace kcrig {

int BushingStiffnessIndex(std::string_view name) {
  if (name.size() < 3 || name.substr(0, 2) != "c_") return -1;
  for (int i = 0; i < kNumBushings; ++i) {
    if (name.substr(2) == kBushingChassisNames[i]) return i;
  }
  return -1;
}

}  // namespace kcrig
