// Cardan angles of the wheel carrier and the small 3x3 helpers the model needs.
//
// Orientation y_rot = (toe psi, camber phi, caster theta), rotations about the
// rig axes z, x, y in that order: R = Rz(psi) Rx(phi) Ry(theta). Angular
// velocities are expressed in the carrier (body) frame, so the mass matrix is
// constant and omega_body = G(angles) * d(angles)/dt.
#ifndef KCRIG_RT_CORE_MODEL_ROTATION_H_
#define KCRIG_RT_CORE_MODEL_ROTATION_H_

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

// [a]x M, column by column as cross products: the zeros of [a]x cost
// nothing, which matters for Jet scalars.
template <typename T, typename Derived>
Mat3<T> SkewTimes(const Vec3<T>& a, const Eigen::MatrixBase<Derived>& m) {
  Mat3<T> out;
  for (int k = 0; k < 3; ++k) {
    out.col(k) = a.cross(Vec3<T>(m.col(k)));
  }
  return out;
}

// Sines and cosines of the Cardan angles, computed once and shared by the
// rotation and the angular-rate matrices.
template <typename T>
class CardanAngles {
 public:
  CardanAngles() = default;  // to be assigned (SuspensionModel::PointState)
  explicit CardanAngles(const Vec3<T>& angles) {
    using std::cos;
    using std::sin;
    for (int k = 0; k < 3; ++k) {
      c_[k] = cos(angles(k));
      s_[k] = sin(angles(k));
    }
  }

  // R = Rz(toe) Rx(camber) Ry(caster): carrier frame -> rig frame.
  Mat3<T> Rotation() const {
    const T &cps = c_[0], &sps = s_[0], &cph = c_[1], &sph = s_[1];
    const T &cth = c_[2], &sth = s_[2];
    Mat3<T> r;
    r << cps * cth - sps * sph * sth, -sps * cph, cps * sth + sps * sph * cth,
        sps * cth + cps * sph * sth, cps * cph, sps * sth - cps * sph * cth,
        -cph * sth, sph, cph * cth;
    return r;
  }

  // G with omega_body = G * d(angles)/dt; column k is R^T dR/d(angle_k) as
  // a vector.
  Mat3<T> RateMatrix() const {
    const T &cph = c_[1], &sph = s_[1], &cth = c_[2], &sth = s_[2];
    Mat3<T> g;
    g << -sth * cph, cth, T(0), sph, T(0), T(1), cth * cph, sth, T(0);
    return g;
  }

  // dG along a change d_angles of the angles.
  Mat3<T> RateMatrixDerivative(const Vec3<T>& d_angles) const {
    const T &cph = c_[1], &sph = s_[1], &cth = c_[2], &sth = s_[2];
    const T &d_phi = d_angles(1), &d_theta = d_angles(2);
    Mat3<T> dg;
    dg << sth * sph * d_phi - cth * cph * d_theta, -sth * d_theta, T(0),
        cph * d_phi, T(0), T(0), -cth * sph * d_phi - sth * cph * d_theta,
        cth * d_theta, T(0);
    return dg;
  }

  // G^-1, singular only at camber = +-90 deg (gimbal lock), far outside any
  // rig travel.
  Mat3<T> InverseRateMatrix() const {
    const T &cph = c_[1], &sph = s_[1], &cth = c_[2], &sth = s_[2];
    Mat3<T> g_inv;
    g_inv << -sth / cph, T(0), cth / cph, cth, T(0), sth, sph * sth / cph, T(1),
        -sph * cth / cph;
    return g_inv;
  }

 private:
  T c_[3];
  T s_[3];
};

template <typename T>
Mat3<T> CardanRotation(const Vec3<T>& angles) {
  return CardanAngles<T>(angles).Rotation();
}

template <typename T>
Mat3<T> AngularRateMatrix(const Vec3<T>& angles) {
  return CardanAngles<T>(angles).RateMatrix();
}

template <typename T>
Mat3<T> InverseAngularRateMatrix(const Vec3<T>& angles) {
  return CardanAngles<T>(angles).InverseRateMatrix();
}

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_ROTATION_H_
