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
// and direction, see Evaluate and AddElementJacobians) and are themselves
// differentiable by Jet, which is what exact sensitivities of the
// semi-implicit step need. Nothing here allocates.
#ifndef KCRIG_RT_CORE_MODEL_SUSPENSION_MODEL_H_
#define KCRIG_RT_CORE_MODEL_SUSPENSION_MODEL_H_

#include <array>
#include <cmath>
#include <type_traits>

#include "rt_core/model/rotation.h"
#include "rt_core/model/suspension_parameters.h"

// Q's evaluation inlines all it calls (Eigen's small fixed-size products, the
// rotation, the element states): a double step a third faster, the
// tangent-linear step a quarter (model_bench). Not under the sanitizers,
// where it would only slow the build.
#if defined(KCRIG_SANITIZED)
#define KCRIG_INLINE_CALLEES
#else
#define KCRIG_INLINE_CALLEES [[gnu::flatten]]
#endif

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

// A bushing's progressive stiffening terms per unit coefficient at
// deflection d = l - l0, their slopes and (when asked for) their
// curvatures: d^3 and |d| d stiffen both ways (symmetric), d^2 one way and
// softens the other (asymmetric; a stiffening in extension only is
// (d^2 + |d| d) / 2).
inline constexpr int kStiffeningTerms = 3;
template <typename T>
void StiffeningTerms(const T& d, std::array<T, kStiffeningTerms>* terms,
                     std::array<T, kStiffeningTerms>* slopes,
                     std::array<T, kStiffeningTerms>* curvatures = nullptr) {
  const double sign = ValueOf(d) < 0 ? -1.0 : 1.0;
  const T squared = d * d;
  *terms = {squared * d, sign * squared, squared};
  *slopes = {T(3) * squared, T(2 * sign) * d, T(2) * d};
  if (curvatures != nullptr) *curvatures = {T(6) * d, T(2 * sign), T(2)};
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
  using Scalar = T;
  static constexpr int kNumElements = kNumBushings + 1;  // + spring-damper

  // Element lengths at the design position (y = 0) become the free lengths,
  // so the design position is the equilibrium under zero rig force.
  explicit SuspensionModel(const SuspensionParameters<T>& parameters);

  const SuspensionParameters<T>& parameters() const { return parameters_; }
  const Mat6<T>& mass_matrix() const { return mass_matrix_; }

  // V(y): dy/dt = V(y) z.
  Mat6<T> KinematicMatrix(const Vec6<T>& y) const {
    Mat6<T> v = Mat6<T>::Identity();
    v.template bottomRightCorner<3, 3>() =
        InverseAngularRateMatrix<T>(y.template tail<3>());
    return v;
  }

  // dQ/dp for the parameters Q is linear in: each element's stiffness and
  // damping (the five bushings in BushingIndex order, then the
  // spring-damper) and the principal inertias (the gyroscopic moment).
  struct LinearParameterJacobian {
    Mat6<T> stiffness;
    Mat6<T> damping;
    Eigen::Matrix<T, 6, 3> inertia;
  };
  // dQ/d of what Q is linear in besides: the effect hooks of each bushing
  // (SetProgressiveStiffness, SetExtraBushingForce) and the load.
  struct HookAndLoadJacobian {
    // One matrix per stiffening term (StiffeningTerms).
    std::array<Eigen::Matrix<T, 6, kNumBushings>, kStiffeningTerms> stiffening;
    Eigen::Matrix<T, 6, kNumBushings> extra_force;
    Eigen::Matrix<T, 6, kNumBushings> extra_stiffness;
    Eigen::Matrix<T, 6, kNumBushings> extra_reference;
    Eigen::Matrix<T, 6, 3> load_force;
    Eigen::Matrix<T, 6, 3> load_point;
  };

  // Q(y, z) under `load`; with `with_jacobians` also dQ/dy and dQ/dz.
  //
  // Derivatives are first taken with respect to q = (r, small body-frame
  // rotation theta) and mapped to Cardan angles through G at the end. For an
  // element with carrier point b, l = |c - r - R b|, u = (c - r - R b) / l
  // and u_b = R^T u, the generalized direction a = [u; b x u_b] gives
  //   dl = -a^T dq,  dl/dt = -a^T z,  Q_e = m a,  m = k (l - l0) + d dl/dt,
  // so dQ_e/dz = -d a a^T and dQ_e/dq = a (d g - k a)^T + m H with
  //   g = [e; b x e_b - w x u_b],  e = (I - u u^T) pdot / l,  e_b = R^T e,
  //   H = [ -W/l       R W_b B/l           ]   W = I - u u^T, B = [b]x,
  //       [ (.)^T      B W_b B/l + B[u_b]x ]   W_b = I - u_b u_b^T.
  //
  // With `parameter_jacobian` (and `hook_jacobian`), also dQ/dp for the
  // parameters (and the hooks and load) Q is linear in, from the same
  // element states. With `with_jacobians` and `point`, also what
  // DifferentiateJacobians reuses at this point (without `with_jacobians`,
  // `point` is left as it was).
  struct PointState;
  KCRIG_INLINE_CALLEES void Evaluate(
      const RigLoad<T>& load, const Vec6<T>& y, const Vec6<T>& z,
      bool with_jacobians, GeneralizedForce<T>* out,
      LinearParameterJacobian* parameter_jacobian = nullptr,
      HookAndLoadJacobian* hook_jacobian = nullptr,
      PointState* point = nullptr) const;

  // dQ/d(hard points of element i) at the point Evaluate kept: columns
  // 0-2 the chassis point's coordinates (rig frame), 3-5 the carrier
  // point's (carrier frame), the free length moving with them. Q is not
  // linear in them; element i's term m a is all that depends on them.
  using HardPointJacobian = Mat6<T>;
  HardPointJacobian HardPointJacobianOf(const PointState& point, int element)
      const requires std::is_floating_point_v<T>;

  // The derivatives along w = (w_y, w_z) of Q's Jacobians at the point
  // Evaluate kept: what Evaluate in Dual scalars at y + eps w_y,
  // z + eps w_z returns in the dual parts of dq_dy, dq_dz and the parameter
  // and hook Jacobians (and HardPointJacobianOf would), in closed form from
  // the second derivatives of each element's state (the tangent-linear
  // step's second-order term, tangent_linear.h). The load is held fixed, and
  // the effect hooks must be those of that Evaluate. For double only (the
  // tangent-linear step differentiates in double; Jet models never need it).
  struct DerivativeRequest {
    bool hooks = false;  // JacobianDerivatives::hooks
    // JacobianDerivatives::hard_points[i] for each element i marked.
    std::array<bool, kNumElements> hard_points{};
  };
  struct JacobianDerivatives {
    Mat6<T> dq_dy;
    Mat6<T> dq_dz;
    LinearParameterJacobian parameters;
    HookAndLoadJacobian hooks;
    std::array<HardPointJacobian, kNumElements> hard_points;
  };
  KCRIG_INLINE_CALLEES void DifferentiateJacobians(
      const PointState& point, const Vec6<T>& w_y, const Vec6<T>& w_z,
      const DerivativeRequest& request,
      JacobianDerivatives* out) const requires std::is_floating_point_v<T>;

  // Unmodelled-effect hooks of the plant (rt_core/model/rig_plant.h); both zero
  // in the nominal model. Stiffening terms on each bushing's axial force
  // (progressive rubber stiffness; in Q and its Jacobian: StiffeningTerms,
  // one coefficient per term and bushing), and an extra
  // axial force per bushing, linearised about a reference deflection
  // (hysteresis, whose state the plant updates after each step; the tangent
  // keeps the semi-implicit step stable when it is stiff).
  struct ExtraBushingForce {
    std::array<T, kNumBushings> force{};      // at the reference [N]
    std::array<T, kNumBushings> stiffness{};  // tangent [N/m]
    std::array<T, kNumBushings> reference{};  // deflection l - l0 [m]
  };
  using StiffeningCoefficients =
      std::array<std::array<T, kNumBushings>, kStiffeningTerms>;
  void SetProgressiveStiffness(const StiffeningCoefficients& coefficients) {
    stiffening_ = coefficients;
  }
  void SetExtraBushingForce(const ExtraBushingForce& extra) { extra_ = extra; }

  // Length change l - l0 of each bushing's link at pose y [m].
  std::array<T, kNumBushings> BushingDeflections(const Vec6<T>& y) const {
    const Mat3<T> rot = CardanAngles<T>(y.template tail<3>()).Rotation();
    std::array<T, kNumBushings> deflections;
    for (int i = 0; i < kNumBushings; ++i) {
      const AxialElement<T>& e = Element(i);
      deflections[i] =
          (e.chassis_point - y.template head<3>() - rot * e.carrier_point)
              .norm() -
          free_length_[i];
    }
    return deflections;
  }

  // Each element's elongation l - l0 [m] and generalized direction
  // a = [u; b x u_b] (a column per element: dl/dt = -a^T z, and an axial
  // force m in it adds m a to Q) at pose y; the five bushings in
  // BushingIndex order, then the spring-damper.
  void ElementGeometry(const Vec6<T>& y, Vec6<T>* elongations,
                       Mat6<T>* directions) const {
    const Mat3<T> rot = CardanAngles<T>(y.template tail<3>()).Rotation();
    const Mat3<T> rot_t = rot.transpose();
    for (int i = 0; i < kNumElements; ++i) {
      const ElementState s =
          StateOf(i, y.template head<3>(), rot, rot_t, Vec6<T>::Zero());
      (*elongations)(i) = s.length - free_length_[i];
      directions->col(i) = s.a;
    }
  }

  // Axial force of each element (the five bushings in BushingIndex order,
  // then the spring-damper), positive in tension [N].
  Vec6<T> ElementForces(const Vec6<T>& y, const Vec6<T>& z) const {
    const Mat3<T> rot = CardanAngles<T>(y.template tail<3>()).Rotation();
    const Mat3<T> rot_t = rot.transpose();
    Vec6<T> forces;
    for (int i = 0; i < kNumElements; ++i) {
      forces(i) = StateOf(i, y.template head<3>(), rot, rot_t, z).magnitude;
    }
    return forces;
  }

 private:
  const AxialElement<T>& Element(int i) const {
    return i < kNumBushings ? parameters_.bushings[i] : parameters_.spring;
  }

  // One element at the pose (r, R): length l, unit vector u from the carrier
  // point to the chassis point (rig frame) and u_b = R^T u, the generalized
  // direction a = [u; b x u_b] (dl/dt = -a^T z) and the axial force
  // m = c (l - l0) + d dl/dt (+ the effect hooks), positive in tension, and
  // its tangent stiffness dm/dl.
  struct ElementState {
    T length;
    Vec3<T> u;
    Vec3<T> u_body;
    Vec6<T> a;
    T magnitude;
    T tangent_stiffness;
  };

  // What the Jacobians of an element's force m a are built from (see
  // Evaluate): the carrier point's velocity, e (world and body frame),
  // dm/dq and W_b B.
  struct ElementJacobianState {
    ElementState element;
    Vec3<T> w;  // omega x b, the carrier point's velocity about r
    Vec3<T> point_velocity;
    T u_dot_point_velocity;
    Vec3<T> e_world;
    Vec3<T> e_body;
    Vec6<T> dmagnitude_dq;
    Vec3<T> u_body_cross_b;
    Mat3<T> w_body_b;
  };

 public:
  // Evaluate's state at one point, for DifferentiateJacobians and
  // HardPointJacobianOf there.
  struct PointState {
    Vec6<T> z;
    Vec3<T> load_point;
    Vec3<T> load_body;
    CardanAngles<T> cardan;
    Mat3<T> rotation;
    Eigen::Matrix<T, 6, 3> dq_dtheta;  // dQ/d(body rotation), before G
    std::array<ElementJacobianState, kNumElements> elements;
  };

 private:
  ElementState StateOf(int i, const Vec3<T>& r, const Mat3<T>& rot,
                       const Mat3<T>& rot_t, const Vec6<T>& z) const {
    const AxialElement<T>& e = Element(i);
    ElementState s;
    const Vec3<T> d = e.chassis_point - r - rot * e.carrier_point;
    s.length = d.norm();
    s.u = d / s.length;
    s.u_body = rot_t * s.u;
    s.a << s.u, e.carrier_point.cross(s.u_body);
    const T deflection = s.length - free_length_[i];
    s.magnitude = e.stiffness * deflection - e.damping * s.a.dot(z);
    s.tangent_stiffness = e.stiffness;
    if (i < kNumBushings) {
      std::array<T, kStiffeningTerms> terms, slopes;
      StiffeningTerms(deflection, &terms, &slopes);
      for (int t = 0; t < kStiffeningTerms; ++t) {
        s.magnitude += stiffening_[t][i] * terms[t];
        s.tangent_stiffness += stiffening_[t][i] * slopes[t];
      }
      s.magnitude += extra_.force[i] +
                     extra_.stiffness[i] * (deflection - extra_.reference[i]);
      s.tangent_stiffness += extra_.stiffness[i];
    }
    return s;
  }

  // (c - b) / l0: the free length's gradient in element i's chassis point
  // c (and minus that in its carrier point b).
  Vec3<T> FreeDirection(int i) const {
    const AxialElement<T>& e = Element(i);
    return (e.chassis_point - e.carrier_point) / free_length_[i];
  }
  // dm/dc and dm/db of element i (see HardPointJacobianOf) from the state
  // Evaluate kept for it at body angular velocity omega.
  struct HardPointForceGradients {
    Vec3<T> chassis;
    Vec3<T> carrier;
  };
  HardPointForceGradients ForceGradientsOf(const ElementJacobianState& j, int i,
                                           const Vec3<T>& omega) const {
    const ElementState& s = j.element;
    const Vec3<T> n0 = FreeDirection(i);
    const T& damping = Element(i).damping;
    return {s.tangent_stiffness * (s.u - n0) - damping * j.e_world,
            s.tangent_stiffness * (n0 - s.u_body) -
                damping * (s.u_body.cross(omega) - j.e_body)};
  }

  // Evaluate's parts for element i in state s: its columns of the hook
  // Jacobian; its terms of dQ/dq (r, theta) and dQ/dz at body velocity
  // (v, omega), and what DifferentiateJacobians reuses in `point`
  // (optional).
  void AddHookColumns(int i, const ElementState& s,
                      HookAndLoadJacobian* hook) const;
  void AddElementJacobians(int i, const ElementState& s, const Vec3<T>& v,
                           const Vec3<T>& omega, const Mat3<T>& rot,
                           const Mat3<T>& rot_t, Mat6<T>* dq_dq, Mat6<T>* dq_dz,
                           PointState* point) const;

  // A direction w = (w_y, w_z) at a point as DifferentiateJacobians moves
  // along it: d denotes the derivative along w; the rotation moves by
  // dR = R [d_theta]x with the body-frame d_theta = G d(angles).
  struct Direction {
    Vec3<T> d_r;
    Vec3<T> d_v;
    Vec3<T> d_omega;
    Vec3<T> d_theta;
    Vec6<T> w_z;
    Mat3<T> rot_t;
  };
  // The rank-one parts of dQ/dq's and dQ/dz's derivatives, summed over
  // the elements after the loop as products of these columns: a, da, dm/dq,
  // d(dm/dq) and the damped da.
  struct RankOneColumns {
    Mat6<T> a;
    Mat6<T> d_a;
    Mat6<T> dm_dq;
    Mat6<T> d_dm_dq;
    Mat6<T> damped_d_a;
  };
  // DifferentiateJacobians' parts, unconstrained: clang 14 instantiates a
  // constrained member of an explicitly instantiated Jet model all the
  // same, and a constrained callee would not resolve there.
  // Element i's share of DifferentiateJacobians: its columns of the
  // derivatives of the parameter and hook Jacobians and of the hard-point
  // Jacobian (when requested), its rank-one columns and its m H term of
  // d(dQ/dq).
  void DifferentiateElement(int i, const PointState& point,
                            const Direction& along,
                            const DerivativeRequest& request,
                            RankOneColumns* columns, Mat6<T>* d_dq_dq,
                            JacobianDerivatives* out) const;
  // What HardPointJacobianOf's derivative needs of the element's state's
  // derivative along the direction (DifferentiateElement).
  struct ElementDerivative {
    T d_m;
    T d_tangent_stiffness;
    Vec3<T> d_u;
    Vec3<T> d_u_body;
    Vec6<T> d_a;
    Vec3<T> d_e_world;
    Vec3<T> d_e_body;
    T m_over_l;
    T d_m_over_l;
    Mat3<T> d_w_body_b;
    Mat3<T> d_h12;
    Mat3<T> d_w_over_l;  // d(m W / l)
  };
  // HardPointJacobianOf, differentiated term by term.
  HardPointJacobian DifferentiateHardPointJacobian(
      int i, const PointState& point, const Direction& along,
      const ElementDerivative& d) const;

  SuspensionParameters<T> parameters_;
  std::array<T, kNumElements> free_length_;
  std::array<Mat3<T>, kNumElements> skew_carrier_point_;
  Mat6<T> mass_matrix_;
  StiffeningCoefficients stiffening_{};
  ExtraBushingForce extra_;
};

template <typename T>
SuspensionModel<T>::SuspensionModel(const SuspensionParameters<T>& parameters)
    : parameters_(parameters) {
  for (int i = 0; i < kNumElements; ++i) {
    const AxialElement<T>& e = Element(i);
    free_length_[i] = (e.chassis_point - e.carrier_point).norm();
    skew_carrier_point_[i] = Skew<T>(e.carrier_point);
  }
  mass_matrix_.setZero();
  mass_matrix_.template topLeftCorner<3, 3>() =
      Mat3<T>::Identity() * parameters_.mass;
  mass_matrix_.template bottomRightCorner<3, 3>() =
      parameters_.inertia.asDiagonal();
}

template <typename T>
void SuspensionModel<T>::Evaluate(const RigLoad<T>& load, const Vec6<T>& y,
                                  const Vec6<T>& z, bool with_jacobians,
                                  GeneralizedForce<T>* out,
                                  LinearParameterJacobian* parameter_jacobian,
                                  HookAndLoadJacobian* hook_jacobian,
                                  PointState* point) const {
  const Vec3<T> r = y.template head<3>();
  const Vec3<T> angles = y.template tail<3>();
  const Vec3<T> v = z.template head<3>();
  const Vec3<T> omega = z.template tail<3>();
  const CardanAngles<T> cardan(angles);
  const Mat3<T> rot = cardan.Rotation();
  const Mat3<T> rot_t = rot.transpose();

  Mat6<T> dq_dq;  // with respect to (r, theta)
  if (with_jacobians) {
    dq_dq.setZero();
    out->dq_dz.setZero();
  }
  const Vec3<T> load_body = rot_t * load.force;
  out->q.template head<3>() = load.force;
  out->q.template tail<3>() = load.point.cross(load_body);
  if (with_jacobians) {
    dq_dq.template block<3, 3>(3, 3) =
        SkewTimes<T>(load.point, Skew<T>(load_body));
  }
  if (hook_jacobian != nullptr) {
    hook_jacobian->load_force << Mat3<T>::Identity(),
        Skew<T>(load.point) * rot_t;
    hook_jacobian->load_point << Mat3<T>::Zero(), -Skew<T>(load_body);
  }

  for (int i = 0; i < kNumElements; ++i) {
    const ElementState element = StateOf(i, r, rot, rot_t, z);
    out->q += element.magnitude * element.a;
    if (parameter_jacobian != nullptr) {
      parameter_jacobian->stiffness.col(i) =
          (element.length - free_length_[i]) * element.a;
      parameter_jacobian->damping.col(i) = -element.a.dot(z) * element.a;
    }
    if (hook_jacobian != nullptr && i < kNumBushings) {
      AddHookColumns(i, element, hook_jacobian);
    }
    if (with_jacobians) {
      AddElementJacobians(i, element, v, omega, rot, rot_t, &dq_dq, &out->dq_dz,
                          point);
    }
  }

  // Gyroscopic moment of the body-frame Euler equations.
  const Vec3<T> angular_momentum = parameters_.inertia.cwiseProduct(omega);
  out->q.template tail<3>() -= omega.cross(angular_momentum);
  if (parameter_jacobian != nullptr) {
    for (int k = 0; k < 3; ++k) {
      Vec3<T> spin = Vec3<T>::Zero();
      spin(k) = omega(k);
      parameter_jacobian->inertia.col(k) << T(0), T(0), T(0),
          -omega.cross(spin);
    }
  }
  if (!with_jacobians) return;
  if (point != nullptr) {
    point->z = z;
    point->load_point = load.point;
    point->load_body = load_body;
    point->cardan = cardan;
    point->rotation = rot;
    point->dq_dtheta = dq_dq.template rightCols<3>();
  }
  out->dq_dz.template block<3, 3>(3, 3) -=
      Skew<T>(omega) * Mat3<T>(parameters_.inertia.asDiagonal()) -
      Skew<T>(angular_momentum);
  out->dq_dy.template leftCols<3>() = dq_dq.template leftCols<3>();
  out->dq_dy.template rightCols<3>() =
      dq_dq.template rightCols<3>() * cardan.RateMatrix();
}

template <typename T>
void SuspensionModel<T>::AddHookColumns(int i, const ElementState& s,
                                        HookAndLoadJacobian* hook) const {
  const T deflection = s.length - free_length_[i];
  std::array<T, kStiffeningTerms> terms, slopes;
  StiffeningTerms(deflection, &terms, &slopes);
  for (int t = 0; t < kStiffeningTerms; ++t) {
    hook->stiffening[t].col(i) = terms[t] * s.a;
  }
  hook->extra_force.col(i) = s.a;
  hook->extra_stiffness.col(i) = (deflection - extra_.reference[i]) * s.a;
  hook->extra_reference.col(i) = -extra_.stiffness[i] * s.a;
}

template <typename T>
void SuspensionModel<T>::AddElementJacobians(
    int i, const ElementState& s, const Vec3<T>& v, const Vec3<T>& omega,
    const Mat3<T>& rot, const Mat3<T>& rot_t, Mat6<T>* dq_dq, Mat6<T>* dq_dz,
    PointState* point) const {
  const AxialElement<T>& e = Element(i);
  const Vec3<T>& b = e.carrier_point;
  const Vec3<T>& u = s.u;
  const Vec3<T>& u_body = s.u_body;
  const Vec6<T>& a = s.a;
  const Vec3<T> w = omega.cross(b);  // carrier-point velocity, body frame
  const Vec3<T> point_velocity = v + rot * w;
  const T u_dot_point_velocity = u.dot(point_velocity);
  const Vec3<T> e_world =
      (point_velocity - u * u_dot_point_velocity) / s.length;
  const Vec3<T> e_body = rot_t * e_world;
  Vec6<T> g;
  g << e_world, b.cross(e_body) - w.cross(u_body);
  const Vec6<T> dmagnitude_dq = e.damping * g - s.tangent_stiffness * a;
  const Vec6<T> damped_a = e.damping * a;
  // Rank-one updates as plain loops: Eigen's generic outer product costs
  // several times more per Jet multiply.
  for (int col = 0; col < 6; ++col) {
    for (int row = 0; row < 6; ++row) {
      (*dq_dq)(row, col) += a(row) * dmagnitude_dq(col);
      (*dq_dz)(row, col) -= damped_a(row) * a(col);
    }
  }

  const Mat3<T>& skew_b = skew_carrier_point_[i];
  const T m_over_l = s.magnitude / s.length;
  // W_b B = B - u_b (u_b^T B), and u_b^T B = (u_b x b)^T.
  const Vec3<T> u_body_cross_b = u_body.cross(b);
  const Mat3<T> w_body_b = skew_b - u_body * u_body_cross_b.transpose();
  if (point != nullptr) {
    point->elements[i] = {s,       w,      point_velocity, u_dot_point_velocity,
                          e_world, e_body, dmagnitude_dq,  u_body_cross_b,
                          w_body_b};
  }
  const Mat3<T> h12 = (rot * w_body_b) * m_over_l;
  dq_dq->template block<3, 3>(0, 0) -=
      m_over_l * (Mat3<T>::Identity() - u * u.transpose());
  dq_dq->template block<3, 3>(0, 3) += h12;
  dq_dq->template block<3, 3>(3, 0) += h12.transpose();
  dq_dq->template block<3, 3>(3, 3) +=
      SkewTimes<T>(b, m_over_l * w_body_b + s.magnitude * Skew<T>(u_body));
}

// Element i's m a with d = c - r - R b and l0 = |c - b|: along a change
// dc of the chassis point, dd = dc; along db of the carrier point,
// dd = -R db, and a = [u; b x u_b] and the carrier point's velocity
// (rate = a^T z = u^T (v + R (omega x b))) move with b as well. So
//   dm/dc = kappa (u - n0) - D e,
//   dm/db = kappa (n0 - u_b) - D (u_b x omega - e_b),
//   da/dc = [W/l; -(R W_b B)^T/l],
//   da/db = [-W R/l; -[u_b]x + (W_b B)^T/l],
// with kappa = dm/dl, D the damping, n0 = (c - b) / l0 and e, W as in
// Evaluate.
template <typename T>
typename SuspensionModel<T>::HardPointJacobian
SuspensionModel<T>::HardPointJacobianOf(const PointState& point, int element)
    const requires std::is_floating_point_v<T> {
  const ElementJacobianState& j = point.elements[element];
  const ElementState& s = j.element;
  const T m_over_l = s.magnitude / s.length;
  const Mat3<T> w_over_l =
      m_over_l * (Mat3<T>::Identity() - s.u * s.u.transpose());
  const Mat3<T> h12 = (point.rotation * j.w_body_b) * m_over_l;
  const HardPointForceGradients dm =
      ForceGradientsOf(j, element, point.z.template tail<3>());
  HardPointJacobian out;
  out.template leftCols<3>() = s.a * dm.chassis.transpose();
  out.template rightCols<3>() = s.a * dm.carrier.transpose();
  out.template block<3, 3>(0, 0) += w_over_l;
  out.template block<3, 3>(3, 0) -= h12.transpose();
  out.template block<3, 3>(0, 3) -= w_over_l * point.rotation;
  out.template block<3, 3>(3, 3) +=
      m_over_l * j.w_body_b.transpose() - s.magnitude * Skew<T>(s.u_body);
  return out;
}

template <typename T>
void SuspensionModel<T>::DifferentiateJacobians(
    const PointState& point, const Vec6<T>& w_y, const Vec6<T>& w_z,
    const DerivativeRequest& request,
    JacobianDerivatives* out) const requires std::is_floating_point_v<T> {
  const Vec3<T> omega = point.z.template tail<3>();
  const Mat3<T>& rot = point.rotation;
  const Mat3<T> rate = point.cardan.RateMatrix();
  const Direction along = {w_y.template head<3>(),
                           w_z.template head<3>(),
                           w_z.template tail<3>(),
                           rate * w_y.template tail<3>(),
                           w_z,
                           rot.transpose()};
  const Vec3<T>& d_theta = along.d_theta;

  Mat6<T> d_dq_dq = Mat6<T>::Zero();  // with respect to (r, theta)
  const Vec3<T> d_load_body = -d_theta.cross(point.load_body);
  d_dq_dq.template block<3, 3>(3, 3) =
      SkewTimes<T>(point.load_point, Skew<T>(d_load_body));
  if (request.hooks) {
    out->hooks.load_force << Mat3<T>::Zero(),
        -SkewTimes<T>(point.load_point, Skew<T>(d_theta)) * along.rot_t;
    out->hooks.load_point << Mat3<T>::Zero(), -Skew<T>(d_load_body);
  }
  RankOneColumns columns;
  for (int i = 0; i < kNumElements; ++i) {
    DifferentiateElement(i, point, along, request, &columns, &d_dq_dq, out);
  }
  d_dq_dq.noalias() += columns.d_a.lazyProduct(columns.dm_dq.transpose());
  d_dq_dq.noalias() += columns.a.lazyProduct(columns.d_dm_dq.transpose());
  const Mat6<T> damped = columns.damped_d_a.lazyProduct(columns.a.transpose());
  Mat6<T>& d_dq_dz = out->dq_dz;
  d_dq_dz = -(damped + damped.transpose());

  // The gyroscopic moment's Jacobians.
  const Vec3<T>& d_omega = along.d_omega;
  const Vec3<T>& inertia = parameters_.inertia;
  const Vec3<T> d_angular_momentum = inertia.cwiseProduct(d_omega);
  d_dq_dz.template block<3, 3>(3, 3) -=
      Skew<T>(d_omega) * Mat3<T>(inertia.asDiagonal()) -
      Skew<T>(d_angular_momentum);
  for (int k = 0; k < 3; ++k) {
    Vec3<T> spin = Vec3<T>::Zero(), d_spin = Vec3<T>::Zero();
    spin(k) = omega(k);
    d_spin(k) = d_omega(k);
    out->parameters.inertia.col(k) << T(0), T(0), T(0),
        -d_omega.cross(spin) - omega.cross(d_spin);
  }

  // dq_dy = [dq_dq_left, dq_dq_right G]: G moves too.
  out->dq_dy.template leftCols<3>() = d_dq_dq.template leftCols<3>();
  out->dq_dy.template rightCols<3>() =
      d_dq_dq.template rightCols<3>() * rate +
      point.dq_dtheta *
          point.cardan.RateMatrixDerivative(w_y.template tail<3>());
}

template <typename T>
void SuspensionModel<T>::DifferentiateElement(int i, const PointState& point,
                                              const Direction& along,
                                              const DerivativeRequest& request,
                                              RankOneColumns* columns,
                                              Mat6<T>* d_dq_dq,
                                              JacobianDerivatives* out) const {
  const AxialElement<T>& e = Element(i);
  const Vec3<T>& b = e.carrier_point;
  const ElementJacobianState& j = point.elements[i];
  const ElementState& s = j.element;
  const T& l = s.length;
  const Vec3<T>& u = s.u;
  const Vec3<T>& u_body = s.u_body;
  const Vec6<T>& a = s.a;
  const Mat3<T>& rot = point.rotation;
  const Vec3<T>& d_theta = along.d_theta;
  const T deflection = l - free_length_[i];

  // The element's state and its derivative along w.
  const Vec3<T> d_vector = -along.d_r - rot * d_theta.cross(b);
  const T d_l = u.dot(d_vector);
  const Vec3<T> d_u = (d_vector - u * d_l) / l;
  const Vec3<T> d_u_body = along.rot_t * d_u - d_theta.cross(u_body);
  Vec6<T> d_a;
  d_a << d_u, b.cross(d_u_body);
  const T rate_along_a = a.dot(point.z);
  const T d_rate_along_a = d_a.dot(point.z) + a.dot(along.w_z);
  const T d_m = s.tangent_stiffness * d_l - e.damping * d_rate_along_a;
  T d_tangent_stiffness = T(0);
  std::array<T, kStiffeningTerms> terms{}, slopes{}, curvatures{};
  if (i < kNumBushings) {
    StiffeningTerms(deflection, &terms, &slopes, &curvatures);
    for (int t = 0; t < kStiffeningTerms; ++t) {
      d_tangent_stiffness += stiffening_[t][i] * curvatures[t] * d_l;
    }
  }

  out->parameters.stiffness.col(i) = d_l * a + deflection * d_a;
  out->parameters.damping.col(i) = -d_rate_along_a * a - rate_along_a * d_a;
  if (request.hooks && i < kNumBushings) {
    for (int t = 0; t < kStiffeningTerms; ++t) {
      out->hooks.stiffening[t].col(i) = slopes[t] * d_l * a + terms[t] * d_a;
    }
    out->hooks.extra_force.col(i) = d_a;
    out->hooks.extra_stiffness.col(i) =
        d_l * a + (deflection - extra_.reference[i]) * d_a;
    out->hooks.extra_reference.col(i) = -extra_.stiffness[i] * d_a;
  }

  // dQ/dz = -d a a^T, dQ/dq = a (d g - k a)^T + m H: the rank-one parts.
  const Vec3<T> d_w = along.d_omega.cross(b);
  const Vec3<T> d_point_velocity = along.d_v + rot * (d_theta.cross(j.w) + d_w);
  const Vec3<T> d_e_world =
      (d_point_velocity - d_u * j.u_dot_point_velocity -
       u * (d_u.dot(j.point_velocity) + u.dot(d_point_velocity)) -
       j.e_world * d_l) /
      l;
  const Vec3<T> d_e_body = along.rot_t * d_e_world - d_theta.cross(j.e_body);
  Vec6<T> d_g;
  d_g << d_e_world, b.cross(d_e_body) - d_w.cross(u_body) - j.w.cross(d_u_body);
  columns->a.col(i) = a;
  columns->d_a.col(i) = d_a;
  columns->damped_d_a.col(i) = e.damping * d_a;
  columns->dm_dq.col(i) = j.dmagnitude_dq;
  columns->d_dm_dq.col(i) =
      e.damping * d_g - d_tangent_stiffness * a - s.tangent_stiffness * d_a;

  // Then m H.
  const T m_over_l = s.magnitude / l;
  const T d_m_over_l = (d_m - m_over_l * d_l) / l;
  const Mat3<T> d_w_body_b = -d_u_body * j.u_body_cross_b.transpose() -
                             u_body * d_u_body.cross(b).transpose();
  const Mat3<T> d_h12 = rot * (SkewTimes<T>(d_theta, j.w_body_b) * m_over_l +
                               d_w_body_b * m_over_l + j.w_body_b * d_m_over_l);
  const Mat3<T> d_u_u = d_u * u.transpose();
  const Mat3<T> d_w_over_l =  // d(m W / l)
      d_m_over_l * (Mat3<T>::Identity() - u * u.transpose()) -
      m_over_l * (d_u_u + d_u_u.transpose());
  d_dq_dq->template block<3, 3>(0, 0) -= d_w_over_l;
  d_dq_dq->template block<3, 3>(0, 3) += d_h12;
  d_dq_dq->template block<3, 3>(3, 0) += d_h12.transpose();
  d_dq_dq->template block<3, 3>(3, 3) += SkewTimes<T>(
      b, d_m_over_l * j.w_body_b + m_over_l * d_w_body_b +
             d_m * Skew<T>(u_body) + s.magnitude * Skew<T>(d_u_body));
  if (request.hard_points[i]) {
    out->hard_points[i] = DifferentiateHardPointJacobian(
        i, point, along,
        {d_m, d_tangent_stiffness, d_u, d_u_body, d_a, d_e_world, d_e_body,
         m_over_l, d_m_over_l, d_w_body_b, d_h12, d_w_over_l});
  }
}

template <typename T>
typename SuspensionModel<T>::HardPointJacobian
SuspensionModel<T>::DifferentiateHardPointJacobian(
    int i, const PointState& point, const Direction& along,
    const ElementDerivative& d) const {
  const ElementJacobianState& j = point.elements[i];
  const ElementState& s = j.element;
  const Vec3<T>& u = s.u;
  const Vec3<T>& u_body = s.u_body;
  const Mat3<T>& rot = point.rotation;
  const Vec3<T> omega = point.z.template tail<3>();
  const Vec3<T> n0 = FreeDirection(i);
  const T& kappa = s.tangent_stiffness;
  const T& damping = Element(i).damping;
  const HardPointForceGradients dm = ForceGradientsOf(j, i, omega);
  HardPointJacobian out;
  out.template leftCols<3>() = d.d_a * dm.chassis.transpose() +
                               s.a * (d.d_tangent_stiffness * (u - n0) +
                                      kappa * d.d_u - damping * d.d_e_world)
                                         .transpose();
  out.template rightCols<3>() =
      d.d_a * dm.carrier.transpose() +
      s.a * (d.d_tangent_stiffness * (n0 - u_body) - kappa * d.d_u_body -
             damping * (d.d_u_body.cross(omega) + u_body.cross(along.d_omega) -
                        d.d_e_body))
                .transpose();
  // W R moves by W R [d_theta]x as well.
  out.template block<3, 3>(0, 0) += d.d_w_over_l;
  out.template block<3, 3>(3, 0) -= d.d_h12.transpose();
  out.template block<3, 3>(0, 3) -=
      d.d_w_over_l * rot +
      d.m_over_l * ((rot - u * (u.transpose() * rot)) * Skew<T>(along.d_theta));
  out.template block<3, 3>(3, 3) += d.d_m_over_l * j.w_body_b.transpose() +
                                    d.m_over_l * d.d_w_body_b.transpose() -
                                    d.d_m * Skew<T>(u_body) -
                                    s.magnitude * Skew<T>(d.d_u_body);
  return out;
}

// Compiled once (suspension_model.cc): the real-time loop and every tool
// step it.
extern template class SuspensionModel<double>;

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_SUSPENSION_MODEL_H_
