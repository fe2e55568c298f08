#include "rt_core/model/static_compliance.h"

#include <cmath>

#include "Eigen/LU"
#include "rt_core/model/rotation.h"
#include "rt_core/model/simulation.h"

namespace kcrig {
namespace {

// dQ/d(load) for a force (rig frame) at carrier point `point` and a moment
// (rig frame): Q's moment part is the body-frame moment point x R^T F.
Mat6<double> LoadMap(const Mat3<double>& rotation, const Vec3<double>& point) {
  Mat6<double> map = Mat6<double>::Zero();
  map.topLeftCorner<3, 3>().setIdentity();
  map.bottomLeftCorner<3, 3>() = Skew<double>(point) * rotation.transpose();
  map.bottomRightCorner<3, 3>() = rotation.transpose();
  return map;
}

}  // namespace

Status ComputeStaticCompliance(const SuspensionParameters<double>& parameters,
                               double contact_patch_z,
                               StaticCompliance* compliance) {
  const SuspensionModel<double> model(parameters);
  const RigLoad<double> no_load;
  *compliance = StaticCompliance();
  KCRIG_RETURN_IF_ERROR(
      SolveStaticEquilibrium(model, no_load, 50, &compliance->rest));
  GeneralizedForce<double> g;
  model.Evaluate(no_load, compliance->rest, Vec6<double>::Zero(),
                 /*with_jacobians=*/true, &g);
  const Eigen::FullPivLU<Mat6<double>> lu(g.dq_dy);
  if (!lu.isInvertible()) {
    return Status::Error("static compliance: singular stiffness");
  }
  compliance->generalized = -lu.inverse();

  const CardanAngles<double> cardan(compliance->rest.tail<3>());
  const Mat3<double> rotation = cardan.Rotation();
  compliance->wheel_centre =
      compliance->generalized * LoadMap(rotation, Vec3<double>::Zero());

  // The contact patch point moves with the carrier: dP = dr + dR p, and
  // dR p = R (omega_body x p) with omega_body = G d(angles).
  const Vec3<double> patch(0, 0, contact_patch_z);
  Mat6<double> to_patch = Mat6<double>::Identity();
  to_patch.topRightCorner<3, 3>() =
      -rotation * Skew<double>(patch) * cardan.RateMatrix();
  compliance->contact_patch_z = contact_patch_z;
  compliance->contact_patch =
      to_patch * compliance->generalized * LoadMap(rotation, patch);
  for (int k = 0; k < 36; ++k) {
    if (!std::isfinite(compliance->contact_patch(k)) ||
        !std::isfinite(compliance->wheel_centre(k))) {
      return Status::Error("static compliance: not finite");
    }
  }
  return Status::Ok();
}

Vec6<double> StaticGradient(const StaticCompliance& compliance,
                            const Vec3<double>& direction, double z_a) {
  const Mat3<double> rotation =
      CardanRotation<double>(compliance.rest.tail<3>());
  const Mat6<double> map = LoadMap(rotation, Vec3<double>(0, 0, z_a));
  return compliance.generalized * map.leftCols<3>() * direction;
}

}  // namespace kcrig
