// The unmodelled effects of DESIGN.md: physical augmentations of the nominal
// model that a real rig has and the estimator's model lacks. They are the
// software rig's truth (`kcrig emulate --effect`, `kcrig simulate --effect`)
// and the diagnosis' candidates. Each is a documented physical model with its
// parameters in SI units. The defaults are plausible for a rubber-bushed
// five-link axle on a servo-hydraulic rig; on the paper's slow 4 s ramp some
// of them stay close to the sensor noise (a rate-dependent effect needs a
// faster ramp or a hold to show).
//
//   bushing_damping        Kelvin-Voigt rubber: every bushing's axial force
//                          gains d * dl/dt.             d [N s/m] = 3e5
//   hysteresis             Dahl friction in every bushing: an extra axial
//                          force h with dh/dl = sigma (1 - h/F sgn(dl/dt)),
//                          solved exactly per step; rate-independent,
//                          |h| < F.                     force F [N] = 400,
//                                                       sigma [N/m] = 4e7
//   progressive_stiffness  rubber stiffening: every bushing's axial force
//                          gains, with d = l - l0, c3 d^3 + c2 |d| d
//                          (symmetric) + a2 d^2 (asymmetric: stiffer one
//                          way; stiffening in extension only is c2 = a2).
//                                                       c3 [N/m^3] = 4e11,
//                                                       c2, a2 [N/m^2] = 0
//   actuator_lag           the force acting on the wheel follows the logged
//                          (load-cell) force through a dead time and a
//                          first-order lag (load cell at the actuator, fixture
//                          dynamics between it and the wheel).
//                                                       tau [s] = 0.05,
//                                                       dead_time [s] = 0.01
//   rig_compliance         the clamped body's mounts give: the measured
//                          wheel-centre position includes F / k per
//                          translational axis, and on the rotational axes
//                          the angles include M / k_rot, M = p x F the
//                          force's moment about the wheel centre (p its
//                          acting point; rx: camber, ry: caster).
//                                                       k [N/m] = 5e7,
//                                                       k_rot [N m/rad] = 5e5
//   sensor_offset          per-channel offset and a common scale error of the
//                          position and angle sensors: m = scale * y + offset.
//                          x, y, z [m] = 1e-4, -1e-4, 5e-5;
//                          toe, camber, caster [rad] = 2e-4, -2e-4, 1e-4;
//                          scale [-] = 1.03
//                          The diagnosis places it on single channels with a
//                          gain error and a coupling from the other channels
//                          of its kind (`mixing`, not a --effect key).
//
// The three bushing effects act in every bushing unless `at` places them
// (`at=bushing:V1`, `at=bushing:O1+bushing:O2`): a worn bushing is one
// component, not the whole axle. rig_compliance acts on the translational
// axes unless `at` places it (`at=fixture:x+fixture:rx`), actuator_lag on
// every force axis unless `at` places it (`at=actuator:y`: one actuator).
#ifndef KCRIG_RT_CORE_MODEL_PLANT_EFFECTS_H_
#define KCRIG_RT_CORE_MODEL_PLANT_EFFECTS_H_

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "base/status.h"
#include "rt_core/model/rotation.h"
#include "rt_core/model/suspension_parameters.h"

namespace kcrig {

inline constexpr std::array<std::string_view, 6> kEffectNames = {
    "bushing_damping", "hysteresis",     "progressive_stiffness",
    "actuator_lag",    "rig_compliance", "sensor_offset"};

// Where a bushing effect acts: one flag per bushing, in BushingIndex order.
using BushingSet = std::array<bool, kNumBushings>;
inline constexpr BushingSet kEveryBushing = {true, true, true, true, true};

// The fixture's axes a rig compliance gives on, as components
// ("fixture:x"): the translations and the rotations about the rig's x and y
// axes (a force acting above the wheel centre has no moment about z there).
inline constexpr int kNumFixtureAxes = 5;
inline constexpr std::string_view kFixtureComponent = "fixture:";
inline constexpr std::array<std::string_view, kNumFixtureAxes>
    kFixtureAxisNames = {"x", "y", "z", "rx", "ry"};
using FixtureAxes = std::array<bool, kNumFixtureAxes>;
inline constexpr FixtureAxes kTranslationalAxes = {true, true, true, false,
                                                   false};
// The actuators' axes an actuator lag acts on, as components ("actuator:x";
// the rig's force channels).
inline constexpr int kNumActuatorAxes = 3;
inline constexpr std::string_view kActuatorComponent = "actuator:";
inline constexpr std::array<std::string_view, kNumActuatorAxes>
    kActuatorAxisNames = {"x", "y", "z"};
using ActuatorAxes = std::array<bool, kNumActuatorAxes>;
inline constexpr ActuatorAxes kEveryActuator = {true, true, true};
// A sensor channel as a component: "sensor:" + kChannelNames.
inline constexpr std::string_view kSensorComponent = "sensor:";
using SensorChannels = std::array<bool, 6>;

// Which effects the plant has and their parameters (SI). Defaults as in the
// table above; `enabled` false means the nominal model. Templated on the
// scalar so that the diagnosis can fit the parameters with exact
// sensitivities (ceres::Jet); the rig and `simulate` use PlantEffects.
template <typename T>
struct BasicPlantEffects {
  struct BushingDamping {
    bool enabled = false;
    T d = T(3e5);  // [N s/m], replaces the model's bushing damping
    BushingSet at = kEveryBushing;
  } bushing_damping;
  struct Hysteresis {
    bool enabled = false;
    T force = T(400);  // Dahl saturation force F [N]
    T sigma = T(4e7);  // Dahl rest stiffness [N/m]
    BushingSet at = kEveryBushing;
  } hysteresis;
  struct ProgressiveStiffness {
    bool enabled = false;
    T c3 = T(4e11);  // [N/m^3]; negative: softening
    T c2 = T(0);     // [N/m^2]; |d| d, symmetric
    T a2 = T(0);     // [N/m^2]; d^2: stiffer in extension when positive
    BushingSet at = kEveryBushing;
  } progressive_stiffness;
  struct ActuatorLag {
    bool enabled = false;
    T tau = T(0.05);        // first-order time constant [s]
    T dead_time = T(0.01);  // [s]
    ActuatorAxes at = kEveryActuator;
  } actuator_lag;
  struct RigCompliance {
    bool enabled = false;
    T k = T(5e7);      // mount stiffness per translational axis [N/m]
    T k_rot = T(5e5);  // per rotational axis [N m/rad]
    FixtureAxes at = kTranslationalAxes;
  } rig_compliance;
  struct SensorOffset {
    bool enabled = false;
    Vec6<T> offset =
        (Vec6<T>() << T(1e-4), T(-1e-4), T(5e-5), T(2e-4), T(-2e-4), T(1e-4))
            .finished();
    T scale = T(1.03);
    // m = scale * (y + mixing * y) + offset: per-channel gain errors on the
    // diagonal, cross-axis couplings off it.
    Mat6<T> mixing = Mat6<T>::Zero();
  } sensor_offset;

  bool any() const {
    return bushing_damping.enabled || hysteresis.enabled ||
           progressive_stiffness.enabled || actuator_lag.enabled ||
           rig_compliance.enabled || sensor_offset.enabled;
  }

  template <typename U>
  BasicPlantEffects<U> Cast() const {
    BasicPlantEffects<U> out;
    out.bushing_damping = {bushing_damping.enabled, U(bushing_damping.d),
                           bushing_damping.at};
    out.hysteresis = {hysteresis.enabled, U(hysteresis.force),
                      U(hysteresis.sigma), hysteresis.at};
    out.progressive_stiffness = {
        progressive_stiffness.enabled, U(progressive_stiffness.c3),
        U(progressive_stiffness.c2), U(progressive_stiffness.a2),
        progressive_stiffness.at};
    out.actuator_lag = {actuator_lag.enabled, U(actuator_lag.tau),
                        U(actuator_lag.dead_time), actuator_lag.at};
    out.rig_compliance = {rig_compliance.enabled, U(rig_compliance.k),
                          U(rig_compliance.k_rot), rig_compliance.at};
    out.sensor_offset.enabled = sensor_offset.enabled;
    for (int k = 0; k < 6; ++k) {
      out.sensor_offset.offset(k) = U(sensor_offset.offset(k));
      for (int j = 0; j < 6; ++j) {
        out.sensor_offset.mixing(k, j) = U(sensor_offset.mixing(k, j));
      }
    }
    out.sensor_offset.scale = U(sensor_offset.scale);
    return out;
  }
};

using PlantEffects = BasicPlantEffects<double>;

// Turns on one effect from "NAME" or "NAME:key=value,key=value" (keys as in
// the table above: d; force, sigma; c3, c2, a2; tau, dead_time; k; x, y, z,
// toe, camber, caster, scale; `at` for the bushing effects, the rig
// compliance and the actuator lag; k_rot for the rig compliance's rotational
// axes, which it then needs in `at`). Errors are one line naming the
// offending part (the caller leads them with where the text came from:
// "--effect ").
Status ParseEffect(std::string_view text, PlantEffects* effects);

// Where a bushing effect of `e` acts; nullptr for the effects that are not
// placed on bushings (the one list of the bushing effects).
template <typename T>
BushingSet* PlacementOf(std::string_view effect, BasicPlantEffects<T>* e) {
  if (effect == "bushing_damping") return &e->bushing_damping.at;
  if (effect == "hysteresis") return &e->hysteresis.at;
  if (effect == "progressive_stiffness") return &e->progressive_stiffness.at;
  return nullptr;
}
inline bool IsBushingEffect(std::string_view effect) {
  PlantEffects any;
  return PlacementOf(effect, &any) != nullptr;
}

// A set of bushings as components, "bushing:O1+bushing:V2" (at least one;
// the chassis-side names of kBushingChassisNames); errors are one line.
Status ParseBushingSet(std::string_view text, BushingSet* set);
std::string DescribeBushingSet(const BushingSet& set);
// The same for fixture axes, "fixture:x+fixture:rx".
Status ParseFixtureAxes(std::string_view text, FixtureAxes* axes);
std::string DescribeFixtureAxes(const FixtureAxes& axes);
// The same for actuator axes, "actuator:x+actuator:y".
Status ParseActuatorAxes(std::string_view text, ActuatorAxes* axes);
std::string DescribeActuatorAxes(const ActuatorAxes& axes);
// The same for sensor channels, "sensor:z+sensor:toe".
Status ParseSensorChannels(std::string_view text, SensorChannels* channels);
std::string DescribeSensorChannels(const SensorChannels& channels);

// The enabled effects with all their parameters, in the --effect syntax
// ("hysteresis:force=150,sigma=4e+07"), for sidecars and messages.
std::vector<std::string> DescribeEffects(const PlantEffects& effects);

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_PLANT_EFFECTS_H_
