// The true plant of the software rig: the suspension model with its "true"
// parameters plus the unmodelled effects of plant_effects.h, stepped with the
// paper's semi-implicit Euler. The emulator runs it in real time at a fine
// step; `kcrig simulate` runs it offline; the diagnosis fits its parameters
// (templated on the scalar: with ceres::Jet it carries exact sensitivities
// of the discrete solution, stepped by the tangent-linear model unless the
// Jet model itself is asked for, as the tests' reference). One
// implementation of each effect.
// Construction allocates (the dead-time line); Settle and Step do not.
#ifndef KCRIG_RT_CORE_MODEL_RIG_PLANT_H_
#define KCRIG_RT_CORE_MODEL_RIG_PLANT_H_

#include <algorithm>
#include <array>
#include <cmath>
#include <type_traits>
#include <vector>

#include "base/status.h"
#include "rt_core/model/plant_effects.h"
#include "rt_core/model/semi_implicit_euler.h"
#include "rt_core/model/simulation.h"
#include "rt_core/model/suspension_model.h"
#include "rt_core/model/tangent_linear.h"
#include "rt_core/model/tare_pose.h"

namespace kcrig {

// The model a plant steps: with Jet scalars the tangent-linear one (the
// same sensitivities as SuspensionModel<Jet>, the reference, for less).
template <typename T>
using PlantModel =
    std::conditional_t<std::is_arithmetic_v<T>, SuspensionModel<T>,
                       TangentLinearModel<T>>;

template <typename T, typename Model = PlantModel<T>>
class BasicRigPlant {
 public:
  // `step` is the integration step h [s] (> 0). The dead-time line holds up
  // to max(max_dead_time, the effect's dead time) [s]: a fit that moves the
  // dead time needs room for its largest value.
  BasicRigPlant(const SuspensionParameters<T>& parameters,
                const BasicPlantEffects<T>& effects, double step,
                double max_dead_time = 0);

  // At rest in static equilibrium under `force` [N] acting at height z_a [m]
  // above the wheel centre, every effect state at rest (no hysteresis force,
  // the lagged force equal to `force`).
  Status Settle(const Vec3<T>& force, const T& z_a);

  // Settle where a rig log's tare puts the sensors: what the rig kept from
  // its last run. Each hysteretic bushing's Dahl force is chosen (|h| <
  // 0.999 F) so that the sensors read the tare's mean (weighted by
  // 1/`sigma`) as nearly as they can (a bushing the run barely moves keeps
  // that force all through the run; one it moves forgets it): a few
  // Gauss-Newton steps on static equilibria, in T (the forces'
  // sensitivities follow the parameters'). With bushing damping the
  // structure may still creep towards its equilibrium: it starts at the
  // pose the sensors read at the first row. With neither: Settle.
  Status SettleAtRest(const Vec3<T>& force, const T& z_a, const TarePose& tare,
                      const Vec6<double>& sigma);

  // Advances one step h; `force` is the force the rig applies at the end of
  // the step as its load cell reads it.
  void Step(const Vec3<T>& force);

  // Moves the force's acting point (the rig's fixture) [m].
  void set_z_a(const T& z_a) { z_a_ = z_a; }
  const T& z_a() const { return z_a_; }

  double step() const { return step_; }
  // True pose: x, y, z [m], toe, camber, caster [rad].
  const Vec6<T>& pose() const { return state_.y; }
  // The force acting on the wheel (differs from the load cell's only with
  // actuator_lag).
  const Vec3<T>& wheel_force() const { return wheel_force_; }
  // hysteresis: the Dahl force per bushing [N] (0 where none).
  const std::array<T, kNumBushings>& dahl_forces() const {
    return hysteresis_.force;
  }
  // What the position and angle sensors read, before noise: the pose with
  // rig_compliance and sensor_offset applied.
  Vec6<T> Sensed() const;
  // Whether the state is finite and within `limit` (m or rad).
  bool Finite(double limit) const;

 private:
  void UpdateHysteresis();
  // The state at rest under `force` before its equilibrium is solved.
  void Rest(const Vec3<T>& force, const T& z_a);
  // Solves the static equilibrium under `force` with the extra bushing
  // forces the model holds, and starts the Dahl elements there.
  Status SolveRest(const Vec3<T>& force);
  // Settle with the Dahl forces `h` locked in (no tangent while settling).
  Status SettleWithDahlForces(const Vec3<T>& force, const T& z_a,
                              const std::array<T, kNumBushings>& h);
  // SettleAtRest's Dahl forces, for the sensors to read `rest`.
  Status SettleWithDahlForcesAtRest(const Vec3<T>& force, const T& z_a,
                                    const Vec6<double>& rest,
                                    const Vec6<double>& sigma);
  // Moves the pose, at rest, to where the sensors read `sensed`.
  void MoveToSensedPose(const Vec6<double>& sensed);
  // The load-cell force `back` steps ago (0: this step's).
  const Vec3<T>& Past(size_t back) const {
    return delay_line_[(delay_head_ + delay_line_.size() - back) %
                       delay_line_.size()];
  }

  BasicPlantEffects<T> effects_;
  Model model_;
  double step_;
  T z_a_ = T(0);
  ModelState<T> state_;
  Vec3<T> wheel_force_ = Vec3<T>::Zero();
  // actuator_lag: the recent load-cell forces; the delayed force is
  // interpolated between the two entries around dead_time (a fractional
  // delay, differentiable in dead_time).
  std::vector<Vec3<T>> delay_line_;
  size_t delay_head_ = 0;
  // The lag over one step for a delayed force linear over it (exact: the
  // logged forces are interpolated linearly), so that a coarse step lags
  // as a fine one does instead of leading by half a step.
  Vec3<T> previous_delayed_ = Vec3<T>::Zero();
  T lag_decay_ = T(0);  // exp(-h / tau)
  T lag_ramp_ = T(1);   // (1 - exp(-h / tau)) tau / h
  // hysteresis: Dahl force per bushing at the deflection it last saw, and
  // its tangent stiffness there.
  typename SuspensionModel<T>::ExtraBushingForce hysteresis_;
};

using RigPlant = BasicRigPlant<double>;

namespace rig_plant_internal {

template <typename T>
SuspensionParameters<T> WithBushingDamping(
    SuspensionParameters<T> parameters, const BasicPlantEffects<T>& effects) {
  if (effects.bushing_damping.enabled) {
    for (int i = 0; i < kNumBushings; ++i) {
      if (effects.bushing_damping.at[i]) {
        parameters.bushings[i].damping = effects.bushing_damping.d;
      }
    }
  }
  return parameters;
}

}  // namespace rig_plant_internal

template <typename T, typename Model>
BasicRigPlant<T, Model>::BasicRigPlant(
    const SuspensionParameters<T>& parameters,
    const BasicPlantEffects<T>& effects, double step, double max_dead_time)
    : effects_(effects),
      model_(rig_plant_internal::WithBushingDamping(parameters, effects)),
      step_(step) {
  using std::exp;
  using std::expm1;
  if (effects_.progressive_stiffness.enabled) {
    const auto& stiffening = effects_.progressive_stiffness;
    const T per_term[kStiffeningTerms] = {stiffening.c3, stiffening.c2,
                                          stiffening.a2};
    typename SuspensionModel<T>::StiffeningCoefficients coefficients{};
    for (int t = 0; t < kStiffeningTerms; ++t) {
      for (int i = 0; i < kNumBushings; ++i) {
        coefficients[t][i] = stiffening.at[i] ? per_term[t] : T(0);
      }
    }
    model_.SetProgressiveStiffness(coefficients);
  }
  size_t delay_steps = 0;
  if (effects_.actuator_lag.enabled) {
    const double longest =
        std::max(max_dead_time, ValueOf(effects_.actuator_lag.dead_time));
    delay_steps = static_cast<size_t>(std::ceil(longest / step_ - 1e-9));
    const T steps_per_tau = step_ / effects_.actuator_lag.tau;
    lag_decay_ = exp(-steps_per_tau);
    lag_ramp_ = -expm1(-steps_per_tau) / steps_per_tau;
  }
  delay_line_.assign(delay_steps + 2, Vec3<T>::Zero());
}

template <typename T, typename Model>
void BasicRigPlant<T, Model>::Rest(const Vec3<T>& force, const T& z_a) {
  z_a_ = z_a;
  hysteresis_ = {};
  std::fill(delay_line_.begin(), delay_line_.end(), force);
  previous_delayed_ = force;
  wheel_force_ = force;
  state_ = ModelState<T>();
}

template <typename T, typename Model>
Status BasicRigPlant<T, Model>::SolveRest(const Vec3<T>& force) {
  RigLoad<T> load;
  load.force = force;
  load.point << T(0), T(0), z_a_;
  const Status status = SolveStaticEquilibrium(model_, load, 50, &state_.y);
  // The Dahl elements start here, with the forces they were solved with.
  if (effects_.hysteresis.enabled) {
    hysteresis_.reference = model_.BushingDeflections(state_.y);
    for (int i = 0; i < kNumBushings; ++i) {
      if (effects_.hysteresis.at[i]) {
        hysteresis_.stiffness[i] = effects_.hysteresis.sigma;
      }
    }
  }
  model_.SetExtraBushingForce(hysteresis_);
  return status;
}

template <typename T, typename Model>
Status BasicRigPlant<T, Model>::Settle(const Vec3<T>& force, const T& z_a) {
  Rest(force, z_a);
  model_.SetExtraBushingForce(hysteresis_);
  return SolveRest(force);
}

template <typename T, typename Model>
Status BasicRigPlant<T, Model>::SettleWithDahlForces(
    const Vec3<T>& force, const T& z_a, const std::array<T, kNumBushings>& h) {
  Rest(force, z_a);
  typename SuspensionModel<T>::ExtraBushingForce locked;
  locked.force = h;
  model_.SetExtraBushingForce(locked);
  hysteresis_.force = h;
  return SolveRest(force);
}

template <typename T, typename Model>
Status BasicRigPlant<T, Model>::SettleAtRest(const Vec3<T>& force, const T& z_a,
                                             const TarePose& tare,
                                             const Vec6<double>& sigma) {
  KCRIG_RETURN_IF_ERROR(
      effects_.hysteresis.enabled
          ? SettleWithDahlForcesAtRest(force, z_a, tare.mean, sigma)
          : Settle(force, z_a));
  if (effects_.bushing_damping.enabled) MoveToSensedPose(tare.at_start);
  return Status::Ok();
}

template <typename T, typename Model>
void BasicRigPlant<T, Model>::MoveToSensedPose(const Vec6<double>& sensed) {
  // The sensors' own effects scale and mix the pose by a few per cent at
  // most: two fixed-point passes.
  for (int pass = 0; pass < 2; ++pass) {
    const Vec6<T> now = Sensed();
    for (int k = 0; k < 6; ++k) state_.y(k) -= now(k) - sensed(k);
  }
  // The Dahl elements see no motion in the move.
  if (effects_.hysteresis.enabled) {
    hysteresis_.reference = model_.BushingDeflections(state_.y);
    model_.SetExtraBushingForce(hysteresis_);
  }
}

template <typename T, typename Model>
Status BasicRigPlant<T, Model>::SettleWithDahlForcesAtRest(
    const Vec3<T>& force, const T& z_a, const Vec6<double>& rest,
    const Vec6<double>& sigma) {
  std::array<T, kNumBushings> h{};
  std::vector<int> placed;
  for (int i = 0; i < kNumBushings; ++i) {
    if (effects_.hysteresis.at[i]) placed.push_back(i);
  }
  const int n = static_cast<int>(placed.size());
  const T limit = T(0.999) * effects_.hysteresis.force;
  const T delta = T(1e-2) * effects_.hysteresis.force;
  auto misfit = [&] {
    const Vec6<T> sensed = Sensed();
    Vec6<T> r;
    for (int k = 0; k < 6; ++k) r(k) = (sensed(k) - rest(k)) / sigma(k);
    return r;
  };
  KCRIG_RETURN_IF_ERROR(SettleWithDahlForces(force, z_a, h));
  // The sensors respond to locked-in forces almost linearly: two steps.
  for (int iteration = 0; iteration < 2; ++iteration) {
    const Vec6<T> r = misfit();
    Eigen::Matrix<T, 6, Eigen::Dynamic> jacobian(6, n);
    for (int k = 0; k < n; ++k) {
      std::array<T, kNumBushings> probe = h;
      probe[placed[k]] += delta;
      KCRIG_RETURN_IF_ERROR(SettleWithDahlForces(force, z_a, probe));
      jacobian.col(k) = (misfit() - r) / delta;
    }
    Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic> normal =
        jacobian.transpose() * jacobian;
    // A bushing the sensors cannot see gets no force (a tiny ridge).
    const T ridge = T(1e-9) * (normal.trace() + T(1e-30));
    normal.diagonal().array() += ridge;
    const Eigen::Matrix<T, Eigen::Dynamic, 1> change =
        normal.ldlt().solve(-jacobian.transpose() * r);
    for (int k = 0; k < n; ++k) {
      T& value = h[placed[k]];
      value += change(k);
      if (ValueOf(value) > ValueOf(limit)) value = limit;
      if (ValueOf(value) < -ValueOf(limit)) value = -limit;
    }
    KCRIG_RETURN_IF_ERROR(SettleWithDahlForces(force, z_a, h));
  }
  return Status::Ok();
}

template <typename T, typename Model>
void BasicRigPlant<T, Model>::Step(const Vec3<T>& force) {
  delay_head_ = (delay_head_ + 1) % delay_line_.size();
  delay_line_[delay_head_] = force;
  if (effects_.actuator_lag.enabled) {
    const T delay = effects_.actuator_lag.dead_time / step_;
    const size_t whole =
        std::min(static_cast<size_t>(std::max(0.0, ValueOf(delay))),
                 delay_line_.size() - 2);
    const T fraction = delay - static_cast<double>(whole);
    const Vec3<T> delayed =
        Past(whole) + (Past(whole + 1) - Past(whole)) * fraction;
    wheel_force_ = delayed - (delayed - previous_delayed_) * lag_ramp_ +
                   (wheel_force_ - previous_delayed_) * lag_decay_;
    previous_delayed_ = delayed;
    for (int axis = 0; axis < kNumActuatorAxes; ++axis) {
      if (!effects_.actuator_lag.at[axis]) wheel_force_(axis) = force(axis);
    }
  } else {
    wheel_force_ = force;
  }
  RigLoad<T> load;
  load.force = wheel_force_;
  load.point << T(0), T(0), z_a_;
  SemiImplicitEulerStep(model_, load, step_, &state_);
  if (effects_.hysteresis.enabled) UpdateHysteresis();
}

// Dahl's model over the step's deflection change (it depends on the path,
// not on time): dh/dl = sigma (1 - h/F s), s = sgn(dl), solved exactly along
// the step, h' = sF - (sF - h) exp(-sigma |dl| / F), so |h| < F for any step.
// The tangent for the next step assumes the motion goes on the same way.
template <typename T, typename Model>
void BasicRigPlant<T, Model>::UpdateHysteresis() {
  using std::abs;
  using std::exp;
  const std::array<T, kNumBushings> deflection =
      model_.BushingDeflections(state_.y);
  const T& f = effects_.hysteresis.force;
  const T& sigma = effects_.hysteresis.sigma;
  for (int i = 0; i < kNumBushings; ++i) {
    if (!effects_.hysteresis.at[i]) continue;  // no Dahl force there
    const T change = deflection[i] - hysteresis_.reference[i];
    T& h = hysteresis_.force[i];
    if (ValueOf(change) != 0.0) {
      const double s = ValueOf(change) > 0 ? 1.0 : -1.0;
      h = s * f - (s * f - h) * exp(-sigma * (s * change) / f);
      hysteresis_.stiffness[i] = sigma * (T(1.0) - h / f * s);
    }
    hysteresis_.reference[i] = deflection[i];
  }
  model_.SetExtraBushingForce(hysteresis_);
}

template <typename T, typename Model>
Vec6<T> BasicRigPlant<T, Model>::Sensed() const {
  Vec6<T> sensed = state_.y;
  const auto& mount = effects_.rig_compliance;
  if (mount.enabled) {
    for (int axis = 0; axis < 3; ++axis) {
      if (mount.at[axis]) sensed(axis) += wheel_force_(axis) / mount.k;
    }
    // The moment about the wheel centre of the force acting at z_a above
    // it, (-z_a F_y, z_a F_x, 0): camber turns about x, caster about y.
    if (mount.at[3]) sensed(4) -= z_a_ * wheel_force_(1) / mount.k_rot;
    if (mount.at[4]) sensed(5) += z_a_ * wheel_force_(0) / mount.k_rot;
  }
  const auto& sensors = effects_.sensor_offset;
  if (sensors.enabled) {
    sensed =
        (sensed + sensors.mixing * sensed) * sensors.scale + sensors.offset;
  }
  return sensed;
}

template <typename T, typename Model>
bool BasicRigPlant<T, Model>::Finite(double limit) const {
  for (int k = 0; k < 6; ++k) {
    const double value = ValueOf(state_.y(k));
    if (!std::isfinite(value) || std::abs(value) > limit) return false;
  }
  return true;
}

extern template class BasicRigPlant<double>;

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_RIG_PLANT_H_
