#include "rt_core/rig_plant.h"

#include <algorithm>
#include <cmath>

#include "rt_core/semi_implicit_euler.h"
#include "rt_core/simulation.h"

namespace kcrig {
namespace {

SuspensionParameters<double> WithBushingDamping(
    SuspensionParameters<double> parameters, const PlantEffects& effects) {
  if (effects.bushing_damping.enabled) {
    for (AxialElement<double>& bushing : parameters.bushings) {
      bushing.damping = effects.bushing_damping.d;
    }
  }
  return parameters;
}

}  // namespace

RigPlant::RigPlant(const SuspensionParameters<double>& parameters,
                   const PlantEffects& effects, double step)
    : effects_(effects),
      model_(WithBushingDamping(parameters, effects)),
      step_(step) {
  if (effects_.progressive_stiffness.enabled) {
    model_.SetProgressiveStiffness(effects_.progressive_stiffness.c3);
  }
  size_t delay_steps = 0;
  if (effects_.actuator_lag.enabled) {
    delay_steps = static_cast<size_t>(
        std::lround(effects_.actuator_lag.dead_time / step_));
    lag_gain_ = -std::expm1(-step_ / effects_.actuator_lag.tau);
  }
  delay_line_.assign(delay_steps + 1, Vec3<double>::Zero());
}

Status RigPlant::Settle(const Vec3<double>& force, double z_a) {
  z_a_ = z_a;
  hysteresis_ = {};
  model_.SetExtraBushingForce(hysteresis_);
  std::fill(delay_line_.begin(), delay_line_.end(), force);
  wheel_force_ = force;
  state_ = ModelState<double>();
  RigLoad<double> load;
  load.force = force;
  load.point << 0, 0, z_a_;
  const Status status = SolveStaticEquilibrium(model_, load, 50, &state_.y);
  if (effects_.hysteresis.enabled) {
    hysteresis_.reference = model_.BushingDeflections(state_.y);
    hysteresis_.stiffness.fill(effects_.hysteresis.sigma);
    model_.SetExtraBushingForce(hysteresis_);
  }
  return status;
}

void RigPlant::Step(const Vec3<double>& force) {
  // The delay line holds the last n+1 load-cell forces; the oldest is the
  // one that left the load cell dead_time ago.
  delay_line_[delay_head_] = force;
  delay_head_ = (delay_head_ + 1) % delay_line_.size();
  const Vec3<double>& delayed = delay_line_[delay_head_];
  wheel_force_ =
      effects_.actuator_lag.enabled
          ? Vec3<double>(wheel_force_ + lag_gain_ * (delayed - wheel_force_))
          : force;
  RigLoad<double> load;
  load.force = wheel_force_;
  load.point << 0, 0, z_a_;
  SemiImplicitEulerStep(model_, load, step_, &state_);
  if (effects_.hysteresis.enabled) UpdateHysteresis();
}

// Dahl's model over the step's deflection change (it depends on the path,
// not on time): dh/dl = sigma (1 - h/F s), s = sgn(dl), solved exactly along
// the step, h' = sF - (sF - h) exp(-sigma |dl| / F), so |h| < F for any step.
// The tangent for the next step assumes the motion goes on the same way.
void RigPlant::UpdateHysteresis() {
  const std::array<double, kNumBushings> deflection =
      model_.BushingDeflections(state_.y);
  const double f = effects_.hysteresis.force;
  const double sigma = effects_.hysteresis.sigma;
  for (int i = 0; i < kNumBushings; ++i) {
    const double change = deflection[i] - hysteresis_.reference[i];
    double& h = hysteresis_.force[i];
    if (change != 0.0) {
      const double s = change > 0 ? 1.0 : -1.0;
      h = s * f - (s * f - h) * std::exp(-sigma * std::abs(change) / f);
      hysteresis_.stiffness[i] = sigma * (1.0 - h / f * s);
    }
    hysteresis_.reference[i] = deflection[i];
  }
  model_.SetExtraBushingForce(hysteresis_);
}

Vec6<double> RigPlant::Sensed() const {
  Vec6<double> sensed = state_.y;
  if (effects_.rig_compliance.enabled) {
    sensed.head<3>() += wheel_force_ / effects_.rig_compliance.k;
  }
  if (effects_.sensor_offset.enabled) {
    sensed =
        effects_.sensor_offset.scale * sensed + effects_.sensor_offset.offset;
  }
  return sensed;
}

bool RigPlant::Finite(double limit) const {
  for (int k = 0; k < 6; ++k) {
    if (!std::isfinite(state_.y(k)) || std::abs(state_.y(k)) > limit) {
      return false;
    }
  }
  return true;
}

}  // namespace kcrig
