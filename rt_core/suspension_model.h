// The wheel carrier as one rigid body on five elastic links and a suspension
// spring-damper, loaded by the K&C rig: equations (1)-(2) of Butz, Simeon,
// Stadler,
//   dy/dt = V(y) z,   M dz/dt = Q(y, z),
// with y = (wheel-centre displacement r [m], toe, camber, caster [rad]) and
// z = (dr/dt [m/s], body-frame angular velocity omega [rad/s]).
//
// Everything is templated on the scalar so the same code runs with double in
// the real-time loop and with ceres::Jet for exact discrete sensitivities.
// dQ/dy and dQ/dz are analytic (the chain rule through each element's length
// and direction, see Evaluate) and are themselves differentiable by Jet, which
// is what exact sensitivities of the semi-implicit step need. Nothing here
// allocates.
#ifndef KCRIG_RT_CORE_SUSPENSION_MODEL_H_
#define KCRIG_RT_CORE_SUSPENSION_MODEL_H_

#include <array>
#include <cmath>
#include <type_traits>

#include "rt_core/rotation.h"
#include "rt_core/suspension_parameters.h"

namespace kcrig {

// The plain double value of a scalar (a double, or the value part of a Jet,
// nested or not).
template <typename T>
double ValueOf(const T& x) {
  if constexpr (std::is_arithmetic_v<T>) {
    return static_cast<double>(x);
  } else {
    return ValueOf(x.a);
  }
}

// The force the rig applies to the wheel.
template <typename T>
struct RigLoad {
  Vec3<T> force = Vec3<T>::Zero();  // rig frame [N]
  Vec3<T> point = Vec3<T>::Zero();  // carrier frame, from the wheel centre [m]
};

template <typename T>
struct ModelState {
  Vec6<T> y = Vec6<T>::Zero();  // x, y, z [m], toe, camber, caster [rad]
  Vec6<T> z = Vec6<T>::Zero();  // dr/dt [m/s], body omega [rad/s]
};

// Q and, when asked for, its partial derivatives.
template <typename T>
struct GeneralizedForce {
  Vec6<T> q;      // rig-frame force [N], carrier-frame moment [N m]
  Mat6<T> dq_dy;  // with respect to (r, Cardan angles)
  Mat6<T> dq_dz;  // with respect to (dr/dt, omega)
};

template <typename T>
class SuspensionModel {
 public:
  // Element lengths at the design position (y = 0) become the free lengths,
  // so the design position is the equilibrium under zero rig force.
  explicit SuspensionModel(const SuspensionParameters<T>& parameters)
      : parameters_(parameters) {
    for (int i = 0; i < kNumElements; ++i) {
      const AxialElement<T>& e = Element(i);
      free_length_[i] = (e.chassis_point - e.carrier_point).norm();
    }
    mass_matrix_.setZero();
    mass_matrix_.template topLeftCorner<3, 3>() =
        Mat3<T>::Identity() * parameters_.mass;
    mass_matrix_.template bottomRightCorner<3, 3>() =
        parameters_.inertia.asDiagonal();
  }

  const SuspensionParameters<T>& parameters() const { return parameters_; }
  const Mat6<T>& mass_matrix() const { return mass_matrix_; }

  // V(y): dy/dt = V(y) z.
  Mat6<T> KinematicMatrix(const Vec6<T>& y) const {
    Mat6<T> v = Mat6<T>::Identity();
    v.template bottomRightCorner<3, 3>() =
        InverseAngularRateMatrix<T>(y.template tail<3>());
    return v;
  }

  // Q(y, z) under `load`; with `with_jacobians` also dQ/dy and dQ/dz.
  void Evaluate(const RigLoad<T>& load, const Vec6<T>& y, const Vec6<T>& z,
                bool with_jacobians, GeneralizedForce<T>* out) const {
    const Vec3<T> r = y.template head<3>();
    const Vec3<T> angles = y.template tail<3>();
    const Vec3<T> v = z.template head<3>();
    const Vec3<T> omega = z.template tail<3>();
    const Mat3<T> rot = CardanRotation<T>(angles);
    const Mat3<T> rot_t = rot.transpose();

    // Derivatives are first taken with respect to q = (r, small body-frame
    // rotation); the rotation columns map to Cardan angles through G below.
    Eigen::Matrix<T, 6, 6> dq_dq;
    if (with_jacobians) {
      dq_dq.setZero();
      out->dq_dz.setZero();
    }
    Vec3<T> force = load.force;
    const Vec3<T> load_body = rot_t * load.force;
    Vec3<T> moment = load.point.cross(load_body);
    if (with_jacobians) {
      dq_dq.template block<3, 3>(3, 3) +=
          Skew<T>(load.point) * Skew<T>(load_body);
    }

    for (int i = 0; i < kNumElements; ++i) {
      const AxialElement<T>& e = Element(i);
      const Vec3<T> lever = rot * e.carrier_point;
      const Vec3<T> d = e.chassis_point - (r + lever);
      const T length = d.norm();
      const Vec3<T> u = d / length;  // carrier point -> chassis point
      const Vec3<T> w = omega.cross(e.carrier_point);  // body frame
      const Vec3<T> point_velocity = v + rot * w;
      const T length_rate = -u.dot(point_velocity);
      const T magnitude =
          e.stiffness * (length - free_length_[i]) + e.damping * length_rate;
      const Vec3<T> f = magnitude * u;  // on the carrier, rig frame
      const Vec3<T> f_body = rot_t * f;
      force += f;
      moment += e.carrier_point.cross(f_body);
      if (!with_jacobians) continue;

      // With l = |d|, u = d/l and f = (c (l - l0) + d_e dl/dt) u:
      //   dl = -u.dp, du = -(I - u u^T) dp / l,
      //   d(dl/dt) = pdot^T (I - u u^T) dp / l + u^T R [w]x dtheta.
      const Mat3<T> skew_b = Skew<T>(e.carrier_point);
      // dp/dq = [I, -R [b]x] for the carrier point p = r + R b.
      Eigen::Matrix<T, 3, 6> dp_dq;
      dp_dq.template leftCols<3>().setIdentity();
      dp_dq.template rightCols<3>() = -rot * skew_b;
      const Mat3<T> transverse = Mat3<T>::Identity() - u * u.transpose();
      const Mat3<T> k_point = -(e.stiffness * u * u.transpose() +
                                (magnitude / length) * transverse);
      Eigen::Matrix<T, 1, 6> dlength_rate_dq =
          (point_velocity.transpose() * transverse * dp_dq) / length;
      dlength_rate_dq.template rightCols<3>() +=
          u.transpose() * rot * Skew<T>(w);
      const Eigen::Matrix<T, 3, 6> df_dq =
          k_point * dp_dq + (e.damping * u) * dlength_rate_dq;
      dq_dq.template topRows<3>() += df_dq;
      Eigen::Matrix<T, 3, 6> dfbody_dq = rot_t * df_dq;
      dfbody_dq.template rightCols<3>() += Skew<T>(f_body);
      dq_dq.template bottomRows<3>() += skew_b * dfbody_dq;

      Eigen::Matrix<T, 1, 6> dlength_rate_dz;
      dlength_rate_dz.template leftCols<3>() = -u.transpose();
      dlength_rate_dz.template rightCols<3>() = u.transpose() * rot * skew_b;
      const Eigen::Matrix<T, 3, 6> df_dz = (e.damping * u) * dlength_rate_dz;
      out->dq_dz.template topRows<3>() += df_dz;
      out->dq_dz.template bottomRows<3>() += skew_b * rot_t * df_dz;
    }

    // Gyroscopic moment of the body-frame Euler equations.
    const Vec3<T> angular_momentum = parameters_.inertia.cwiseProduct(omega);
    moment -= omega.cross(angular_momentum);

    out->q.template head<3>() = force;
    out->q.template tail<3>() = moment;
    if (!with_jacobians) return;
    out->dq_dz.template block<3, 3>(3, 3) -=
        Skew<T>(omega) * Mat3<T>(parameters_.inertia.asDiagonal()) -
        Skew<T>(angular_momentum);
    out->dq_dy.template leftCols<3>() = dq_dq.template leftCols<3>();
    out->dq_dy.template rightCols<3>() =
        dq_dq.template rightCols<3>() * AngularRateMatrix<T>(angles);
  }

 private:
  static constexpr int kNumElements = kNumBushings + 1;  // + spring-damper

  const AxialElement<T>& Element(int i) const {
    return i < kNumBushings ? parameters_.bushings[i] : parameters_.spring;
  }

  SuspensionParameters<T> parameters_;
  std::array<T, kNumElements> free_length_;
  Mat6<T> mass_matrix_;
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_SUSPENSION_MODEL_H_
