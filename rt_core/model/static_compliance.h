// The model's static compliance at zero speed: how the equilibrium pose
// under zero load moves under a small force or moment, from the analytic
// Jacobian dQ/dy of the generalized force (paper eq. 1 with z = 0):
//   dQ/dy dy + dQ/dload dload = 0  =>  dy = -(dQ/dy)^-1 dQ/dload.
// What Adams Car and MotionView report as the wheel-centre compliance
// matrix, and what a K&C rig's gradients tend to when the ramp is slow.
#ifndef KCRIG_RT_CORE_MODEL_STATIC_COMPLIANCE_H_
#define KCRIG_RT_CORE_MODEL_STATIC_COMPLIANCE_H_

#include "base/status.h"
#include "rt_core/model/suspension_model.h"

namespace kcrig {

struct StaticCompliance {
  // The equilibrium pose under zero load: x, y, z [m], toe, camber, caster
  // [rad].
  Vec6<double> rest = Vec6<double>::Zero();
  // Columns: a force Fx, Fy, Fz [N] acting at the wheel centre and a moment
  // Mx, My, Mz [N m] about it, in the rig frame. Rows: the wheel centre's
  // x, y, z [m] and the carrier's toe, camber, caster [rad].
  Mat6<double> wheel_centre = Mat6<double>::Zero();
  // The same for a force and moment acting at the contact patch (the
  // carrier point (0, 0, contact_patch_z) below the wheel centre). Rows: the
  // contact patch point's x, y, z [m] and the carrier's angles [rad].
  double contact_patch_z = 0;  // [m]
  Mat6<double> contact_patch = Mat6<double>::Zero();
  // dy = generalized * dQ: the raw inverse, for loads at any point.
  Mat6<double> generalized = Mat6<double>::Zero();
};

// The compliance of `parameters` at its equilibrium under zero load. Errors
// when the equilibrium cannot be found or the stiffness is singular.
Status ComputeStaticCompliance(const SuspensionParameters<double>& parameters,
                               double contact_patch_z,
                               StaticCompliance* compliance);

// d(pose)/d(magnitude) of a force along unit `direction` (rig frame) acting
// at carrier point (0, 0, z_a): the static gradient a K&C ramp along
// `direction` at height z_a measures when it is slow.
Vec6<double> StaticGradient(const StaticCompliance& compliance,
                            const Vec3<double>& direction, double z_a);

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_STATIC_COMPLIANCE_H_
