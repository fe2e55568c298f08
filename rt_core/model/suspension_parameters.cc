#include "rt_core/model/suspension_parameters.h"

namespace kcrig {

int BushingStiffnessIndex(std::string_view name) {
  if (name.size() < 3 || name.substr(0, 2) != "c_") return -1;
  for (int i = 0; i < kNumBushings; ++i) {
    if (name.substr(2) == kBushingChassisNames[i]) return i;
  }
  return -1;
}

bool IsHardPoint(std::string_view name) {
  bool known = name == "spring_chassis" || name == "spring_carrier";
  for (int i = 0; i < kNumBushings; ++i) {
    known = known || name == kBushingChassisNames[i] ||
            name == kBushingCarrierNames[i];
  }
  return known;
}

std::string ComponentOfParameter(std::string_view name) {
  const size_t dot = name.find('.');
  if (dot != std::string_view::npos) {
    const std::string_view axis = name.substr(dot + 1);
    if (axis != "x" && axis != "y" && axis != "z") return "";
    name = name.substr(0, dot);
    return IsHardPoint(name) ? "hardpoint:" + std::string(name) : "";
  }
  if (IsHardPoint(name)) return "hardpoint:" + std::string(name);
  if (name == "k_spring") return "strut:spring";
  if (name == "d_damper") return "strut:damper";
  if (name == "mass") return "carrier:mass";
  if (name == "Jxx" || name == "Jyy" || name == "Jzz") return "carrier:inertia";
  if (name.size() > 2 &&
      (name.substr(0, 2) == "c_" || name.substr(0, 2) == "d_")) {
    for (int i = 0; i < kNumBushings; ++i) {
      if (name.substr(2) == kBushingChassisNames[i]) {
        return std::string(kBushingComponent) +
               std::string(kBushingChassisNames[i]);
      }
    }
  }
  return "";
}

}  // namespace kcrig
