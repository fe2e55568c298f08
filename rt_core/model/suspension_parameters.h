// Physical parameters of the single-body multi-link suspension model.
//
// Frame: ISO 8855 rig frame (x forward, y left, z up) with the origin at the
// wheel centre in design position. SI units throughout (m, kg, N, s). Values
// come from config/model.yaml; nothing here has a physical default.
#ifndef KCRIG_RT_CORE_MODEL_SUSPENSION_PARAMETERS_H_
#define KCRIG_RT_CORE_MODEL_SUSPENSION_PARAMETERS_H_

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "rt_core/model/rotation.h"

namespace kcrig {

// An axial spring-damper between a carrier point and a chassis point. For a
// link it is the rubber bushing at the chassis end of a rigid massless rod; its
// force along the rod is stiffness * (l - l0) + damping * dl/dt, with l0 the
// length in design position (the model is in equilibrium there).
template <typename T>
struct AxialElement {
  Vec3<T> carrier_point;  // carrier frame, relative to the wheel centre [m]
  Vec3<T> chassis_point;  // rig frame [m]
  T stiffness;            // [N/m]
  T damping;              // [N s/m]
};

// The five links in the paper's order; the bushing sits at the chassis point.
enum BushingIndex { kO1 = 0, kO2, kV1, kV2, kP, kNumBushings };

// Paper names: chassis points O1 O2 V1 V2 P, carrier points N1 N2 U1 U2 Q.
inline constexpr std::array<std::string_view, kNumBushings>
    kBushingChassisNames = {"O1", "O2", "V1", "V2", "P"};
inline constexpr std::array<std::string_view, kNumBushings>
    kBushingCarrierNames = {"N1", "N2", "U1", "U2", "Q"};

template <typename T>
struct SuspensionParameters {
  T mass;           // wheel carrier + clamped wheel [kg]
  Vec3<T> inertia;  // principal inertia about the wheel centre
                    // (Jxx, Jyy, Jzz) in the carrier frame [kg m^2]
  std::array<AxialElement<T>, kNumBushings> bushings;
  AxialElement<T> spring;  // suspension spring and damper

  template <typename U>
  SuspensionParameters<U> Cast() const {
    SuspensionParameters<U> out;
    out.mass = U(mass);
    out.inertia = inertia.template cast<U>();
    for (int i = 0; i < kNumBushings; ++i) {
      out.bushings[i] = CastElement<U>(bushings[i]);
    }
    out.spring = CastElement<U>(spring);
    return out;
  }

 private:
  template <typename U>
  static AxialElement<U> CastElement(const AxialElement<T>& e) {
    return {e.carrier_point.template cast<U>(),
            e.chassis_point.template cast<U>(), U(e.stiffness), U(e.damping)};
  }
};

// A scalar parameter addressable by name (for --set, sidecar truth, the
// estimator's parameter selection). Names: c_O1..c_P (bushing stiffness),
// d_O1..d_P (bushing damping), k_spring, d_damper, mass, Jxx, Jyy, Jzz and
// hard-point coordinates O1.x .. Q.z, spring_chassis.x, spring_carrier.x ...
template <typename T>
struct NamedParameter {
  std::string name;
  std::string unit;
  T* value;
};

template <typename T>
std::vector<NamedParameter<T>> ListParameters(SuspensionParameters<T>* p) {
  std::vector<NamedParameter<T>> list;
  for (int i = 0; i < kNumBushings; ++i) {
    list.push_back({"c_" + std::string(kBushingChassisNames[i]), "N/m",
                    &p->bushings[i].stiffness});
  }
  for (int i = 0; i < kNumBushings; ++i) {
    list.push_back({"d_" + std::string(kBushingChassisNames[i]), "N s/m",
                    &p->bushings[i].damping});
  }
  list.push_back({"k_spring", "N/m", &p->spring.stiffness});
  list.push_back({"d_damper", "N s/m", &p->spring.damping});
  list.push_back({"mass", "kg", &p->mass});
  const char* axes[3] = {"x", "y", "z"};
  const char* inertia_names[3] = {"Jxx", "Jyy", "Jzz"};
  for (int k = 0; k < 3; ++k) {
    list.push_back({inertia_names[k], "kg m^2", &p->inertia(k)});
  }
  auto add_point = [&](const std::string& name, Vec3<T>* point) {
    for (int k = 0; k < 3; ++k) {
      list.push_back({name + "." + axes[k], "m", &(*point)(k)});
    }
  };
  for (int i = 0; i < kNumBushings; ++i) {
    add_point(std::string(kBushingChassisNames[i]),
              &p->bushings[i].chassis_point);
    add_point(std::string(kBushingCarrierNames[i]),
              &p->bushings[i].carrier_point);
  }
  add_point("spring_chassis", &p->spring.chassis_point);
  add_point("spring_carrier", &p->spring.carrier_point);
  return list;
}

// The parameter called `name` (ListParameters' names) in `p`, or nullptr.
template <typename T>
T* FindParameter(SuspensionParameters<T>* p, const std::string& name) {
  for (const NamedParameter<T>& named : ListParameters(p)) {
    if (named.name == name) return named.value;
  }
  return nullptr;
}
template <typename T>
const T* FindParameter(const SuspensionParameters<T>& p,
                       const std::string& name) {
  // ListParameters hands out pointers for writing; none is written here.
  return FindParameter(const_cast<SuspensionParameters<T>*>(&p), name);
}

// Index of the bushing whose stiffness is called `name` ("c_O1"), or -1.
int BushingStiffnessIndex(std::string_view name);

// The component prefix of a bushing: "bushing:" + its chassis-side name.
inline constexpr std::string_view kBushingComponent = "bushing:";

// Where the parameter called `name` (ListParameters' names) lives, in the
// diagnosis' component vocabulary: "bushing:O1" (c_O1, d_O1),
// "strut:spring" (k_spring), "strut:damper" (d_damper), "carrier:mass"
// (mass), "carrier:inertia" (Jxx, Jyy, Jzz), "hardpoint:O1" (O1.x, O1.y,
// O1.z, and the point O1 with all three; likewise the carrier points N1 ..
// Q and spring_chassis, spring_carrier); "" for a name that is none of
// these.
std::string ComponentOfParameter(std::string_view name);

// Whether `name` is a hard point (O1 .. P, N1 .. Q, spring_chassis,
// spring_carrier): its coordinates are NAME.x, NAME.y, NAME.z.
bool IsHardPoint(std::string_view name);

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_SUSPENSION_PARAMETERS_H_
