// The K&C rig excitation of the paper's section 5: a horizontal force whose
// magnitude ramps linearly from -Fmax to +Fmax over [0, tf], in the direction
// phi of the x-y plane, acting at height z_a relative to the wheel centre:
//   Fx = ((2t - tf)/tf) Fmax cos(phi),  Fy = ((2t - tf)/tf) Fmax sin(phi).
// Optionally followed by a hold at +Fmax and a return ramp +Fmax -> -Fmax
// (unloading, and a second rate): what tells rate-dependent effects (damping,
// lag) from rate-independent ones (hysteresis, offsets). Before 0 and after
// the end the end values hold. Templated so that phi and z_a can carry
// derivatives for the experimental design.
#ifndef KCRIG_RT_CORE_MODEL_EXCITATION_H_
#define KCRIG_RT_CORE_MODEL_EXCITATION_H_

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string_view>
#include <vector>

#include "rt_core/model/suspension_model.h"

namespace kcrig {

template <typename T>
struct RampExcitation {
  T phi = T(0);         // force direction from +x towards +y [rad]
  T z_a = T(0);         // acting point height above the wheel centre [m]
  T fmax = T(0);        // ramp amplitude [N]
  double duration = 0;  // tf [s], > 0
  double hold = 0;      // hold at +Fmax after the ramp [s], >= 0
  // Return ramp +Fmax -> -Fmax after the hold [s]; 0: none.
  double return_duration = 0;

  // Time of the excitation's end [s].
  double EndTime() const { return duration + hold + return_duration; }

  // The normalised force level in [-1, 1]: (2t - tf)/tf on the ramp, 1 on
  // the hold, then down to -1 over the return; end values outside.
  double Profile(double t) const {
    const double turn = duration + hold;
    if (return_duration > 0 && t > turn) {
      return std::max(1.0 - 2.0 * (t - turn) / return_duration, -1.0);
    }
    return std::clamp((2.0 * t - duration) / duration, -1.0, 1.0);
  }

  RigLoad<T> LoadAt(double t) const {
    using std::cos;
    using std::sin;
    RigLoad<T> load;
    const T magnitude = fmax * Profile(t);
    load.force << magnitude * cos(phi), magnitude * sin(phi), T(0);
    load.point << T(0), T(0), z_a;
    return load;
  }

  template <typename U>
  RampExcitation<U> Cast() const {
    return {U(phi), U(z_a), U(fmax), duration, hold, return_duration};
  }
};

// A load given by forces sampled at a fixed period (a rig log's load cell),
// linearly interpolated between samples and held after the last one, acting
// at height z_a. Times are relative to the first sample.
template <typename T>
struct SampledLoad {
  const std::vector<Vec3<double>>* forces = nullptr;  // at t = j * period
  double period = 0;                                  // [s]
  T z_a = T(0);                                       // [m]
  double duration = 0;                                // (n - 1) * period

  double EndTime() const { return duration; }

  RigLoad<T> LoadAt(double t) const {
    const double position =
        std::clamp(t / period, 0.0, static_cast<double>(forces->size() - 1));
    const size_t j =
        std::min(static_cast<size_t>(position), forces->size() - 2);
    const double w = position - static_cast<double>(j);
    RigLoad<T> load;
    load.force =
        ((1.0 - w) * (*forces)[j] + w * (*forces)[j + 1]).template cast<T>();
    load.point << T(0), T(0), z_a;
    return load;
  }
};

// The whole force history of a rig run, as a level in multiples of Fmax that
// is piecewise linear over consecutive phases: the rig starts at rest at zero
// force, the sensors are tared, the force leads in to -Fmax and settles, the
// paper's ramp runs -Fmax -> +Fmax over tf, optionally holds and returns to
// -Fmax, and the force ramps back to zero. The ramp, hold and return are
// RampExcitation::Profile itself, so that the loop and the offline model
// ask for the same force.
// Allocation-free; the real-time loop evaluates it every cycle.
enum class RunPhase : std::uint8_t {
  kTare = 0,  // at rest, zero force: the rest pose is measured
  kLeadIn,    // 0 -> -Fmax
  kSettle,    // hold -Fmax
  kRamp,      // -Fmax -> +Fmax over tf (the paper's excitation)
  kHold,      // hold +Fmax (skipped when its time is 0)
  kReturn,    // +Fmax -> -Fmax (skipped when its time is 0)
  kRampDown,  // to 0
  kDone,
};

const char* RunPhaseName(RunPhase phase);

// The static name (RunPhaseName) of the phase called `text`; empty when no
// phase is called so.
std::string_view RunPhaseNamed(std::string_view text);

struct RunProfileTimes {
  double tare = 0.2;       // [s]
  double lead_in = 1.0;    // [s]
  double settle = 0.5;     // [s]
  double ramp_down = 1.0;  // [s]
};

class RunProfile {
 public:
  RunProfile() = default;
  // The phases around `excitation`'s ramp, hold and return (its direction,
  // height and amplitude do not matter: the level is normalised).
  RunProfile(const RunProfileTimes& times,
             const RampExcitation<double>& excitation);

  // Level in [-1, 1] and phase at time t from the start [s]; kDone (level
  // 0) after the last phase.
  double Level(double t) const;
  RunPhase Phase(double t) const;
  double duration() const { return end_[kNumPhases - 1]; }
  // Start time of the paper's ramp [s].
  double ramp_start() const { return end_[2]; }

 private:
  static constexpr int kNumPhases = 7;
  std::array<double, kNumPhases> end_{};    // end time of each phase
  std::array<double, kNumPhases> level_{};  // level at the end of each phase
  RampExcitation<double> excitation_;       // unit amplitude
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_EXCITATION_H_
