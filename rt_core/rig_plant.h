// The true plant of the software rig: the suspension model with its "true"
// parameters plus the unmodelled effects of plant_effects.h, stepped with the
// paper's semi-implicit Euler. The emulator runs it in real time at a fine
// step; `kcrig simulate` runs it offline. One implementation of each effect.
// Construction allocates (the dead-time line); Settle and Step do not.
#ifndef KCRIG_RT_CORE_RIG_PLANT_H_
#define KCRIG_RT_CORE_RIG_PLANT_H_

#include <array>
#include <vector>

#include "rt_core/plant_effects.h"
#include "rt_core/status.h"
#include "rt_core/suspension_model.h"

namespace kcrig {

class RigPlant {
 public:
  // `step` is the integration step h [s] (> 0).
  RigPlant(const SuspensionParameters<double>& parameters,
           const PlantEffects& effects, double step);

  // At rest in static equilibrium under `force` [N] acting at height z_a [m]
  // above the wheel centre, every effect state at rest (no hysteresis force,
  // the lagged force equal to `force`).
  Status Settle(const Vec3<double>& force, double z_a);

  // Advances one step h; `force` is the force the rig applies at the end of
  // the step as its load cell reads it.
  void Step(const Vec3<double>& force);

  // Moves the force's acting point (the rig's fixture) [m].
  void set_z_a(double z_a) { z_a_ = z_a; }

  double step() const { return step_; }
  // True pose: x, y, z [m], toe, camber, caster [rad].
  const Vec6<double>& pose() const { return state_.y; }
  // The force acting on the wheel (differs from the load cell's only with
  // actuator_lag).
  const Vec3<double>& wheel_force() const { return wheel_force_; }
  // What the position and angle sensors read, before noise: the pose with
  // rig_compliance and sensor_offset applied.
  Vec6<double> Sensed() const;
  // Whether the state is finite and within `limit` (m or rad).
  bool Finite(double limit) const;

 private:
  void UpdateHysteresis();

  PlantEffects effects_;
  SuspensionModel<double> model_;
  double step_;
  double z_a_ = 0;
  ModelState<double> state_;
  Vec3<double> wheel_force_ = Vec3<double>::Zero();
  // actuator_lag: the load-cell force of the last dead_time / step steps.
  std::vector<Vec3<double>> delay_line_;
  size_t delay_head_ = 0;
  double lag_gain_ = 1;  // 1 - exp(-h / tau)
  // hysteresis: Dahl force per bushing at the deflection it last saw, and
  // its tangent stiffness there.
  SuspensionModel<double>::ExtraBushingForce hysteresis_;
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_RIG_PLANT_H_
