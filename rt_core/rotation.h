// Cardan angles of the wheel carrier and the small 3x3 helpers the model needs.
//
// Orientation y_rot = (toe psi, camber phi, caster theta), rotations about the
// rig axes z, x, y in that order: R = Rz(psi) Rx(phi) Ry(theta). Angular
// velocities are expressed in the carrier (body) frame, so the mass matrix is
// constant and omega_body = G(angles) * d(angles)/dt.
#ifndef KCRIG_RT_CORE_ROTATION_H_
#define KCRIG_RT_CORE_ROTATION_H_

#include <cmath>

#include "Eigen/Core"
#include "Eigen/Geometry"

namespace kcrig {

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Mat3 = Eigen::Matrix<T, 3, 3>;
template <typename T>
using Vec6 = Eigen::Matrix<T, 6, 1>;
template <typename T>
using Mat6 = Eigen::Matrix<T, 6, 6>;

template <typename T>
Mat3<T> Skew(const Vec3<T>& a) {
  Mat3<T> s;
  s << T(0), -a(2), a(1), a(2), T(0), -a(0), -a(1), a(0), T(0);
  return s;
}

// R = Rz(toe) Rx(camber) Ry(caster): carrier frame -> rig frame.
template <typename T>
Mat3<T> CardanRotation(const Vec3<T>& angles) {
  using std::cos;
  using std::sin;
  const T cps = cos(angles(0)), sps = sin(angles(0));
  const T cph = cos(angles(1)), sph = sin(angles(1));
  const T cth = cos(angles(2)), sth = sin(angles(2));
  Mat3<T> rz, rx, ry;
  rz << cps, -sps, T(0), sps, cps, T(0), T(0), T(0), T(1);
  rx << T(1), T(0), T(0), T(0), cph, -sph, T(0), sph, cph;
  ry << cth, T(0), sth, T(0), T(1), T(0), -sth, T(0), cth;
  return rz * rx * ry;
}

// G with omega_body = G * d(angles)/dt; column k is R^T dR/d(angle_k) as a
// vector.
template <typename T>
Mat3<T> AngularRateMatrix(const Vec3<T>& angles) {
  using std::cos;
  using std::sin;
  const T cph = cos(angles(1)), sph = sin(angles(1));
  const T cth = cos(angles(2)), sth = sin(angles(2));
  Mat3<T> g;
  g << -sth * cph, cth, T(0), sph, T(0), T(1), cth * cph, sth, T(0);
  return g;
}

// G^-1, singular only at camber = +-90 deg (gimbal lock), far outside any rig
// travel.
template <typename T>
Mat3<T> InverseAngularRateMatrix(const Vec3<T>& angles) {
  using std::cos;
  using std::sin;
  const T cph = cos(angles(1)), sph = sin(angles(1));
  const T cth = cos(angles(2)), sth = sin(angles(2));
  Mat3<T> g_inv;
  g_inv << -sth / cph, T(0), cth / cph, cth, T(0), sth, sph * sth / cph, T(1),
      -sph * cth / cph;
  return g_inv;
}

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_ROTATION_H_
