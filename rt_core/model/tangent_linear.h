// Exact forward sensitivities of the semi-implicit Euler at the cost of a few
// extra evaluations of Q instead of a Jet-valued step: the tangent-linear
// model of the *discrete* step, so the sensitivities stay the exact
// derivatives of what is simulated (those the Jet reference computes).
//
// The step (semi_implicit_euler.h) solves W dz = h Q with
//   W v = M v - DQ[w(v)],   w(v) = (h^2 V v, h v),
// DQ[w] the directional derivative of Q at the predicted pose (y_p, z) and
// V = diag(I, G^-1(y)). Along a direction d of (state, parameters, load):
//   W d(dz) = h dQ - dM dz + d(DQ[w(dz)]),
// where d(DQ[w]) is taken with dz held fixed (through the pose, the
// parameters and G^-1(y)). W is factored once in double and solves all N
// directions; the state then moves as in the step, in J arithmetic. The
// right-hand side comes from Q's Jacobians in the state and in every input
// that carries tangents (stiffness, damping, inertia, hard points, the
// effect hooks and the load) and their derivatives along w in closed form
// (SuspensionModel::DifferentiateJacobians): by the symmetry of second
// derivatives d(DQ[w]) = D(dQ/dx)[w] dx + D(dQ/dp)[w] dp, a product per
// input (cost nearly independent of N); the mass's through dM dz.
//
// J is a Jet of N directions (value .a, derivatives .v, e.g. ceres::Jet):
// the same type the Jet reference uses, so the two are interchangeable.
#ifndef KCRIG_RT_CORE_MODEL_TANGENT_LINEAR_H_
#define KCRIG_RT_CORE_MODEL_TANGENT_LINEAR_H_

#include <array>

#include "Eigen/LU"
#include "base/status.h"
#include "rt_core/model/semi_implicit_euler.h"
#include "rt_core/model/suspension_model.h"

namespace kcrig {

template <typename J>
class TangentLinearModel {
 public:
  using Scalar = J;
  static constexpr int kDirections = J::DIMENSION;

  // Parameters with their tangents: parameter p carries dp in its .v.
  explicit TangentLinearModel(const SuspensionParameters<J>& parameters)
      : values_(ValuesOf(parameters)), jets_(parameters) {
    for (int i = 0; i < kNumElements; ++i) {
      const AxialElement<J>& e =
          i < kNumBushings ? parameters.bushings[i] : parameters.spring;
      for (int k = 0; k < 3; ++k) {
        hard_point_tangents_[i].row(k) = e.chassis_point(k).v.transpose();
        hard_point_tangents_[i].row(k + 3) = e.carrier_point(k).v.transpose();
      }
      hard_point_carries_[i] = AnyTangent(hard_point_tangents_[i]);
      stiffness_tangents_.row(i) = e.stiffness.v.transpose();
      damping_tangents_.row(i) = e.damping.v.transpose();
    }
    mass_tangents_ = parameters.mass.v.transpose();
    for (int k = 0; k < 3; ++k) {
      inertia_tangents_.row(k) = parameters.inertia(k).v.transpose();
    }
    stiffness_carries_ = AnyTangent(stiffness_tangents_);
    damping_carries_ = AnyTangent(damping_tangents_);
    inertia_carries_ = AnyTangent(inertia_tangents_);
  }

  // Length change of each bushing's link at pose y, with tangents.
  std::array<J, kNumBushings> BushingDeflections(const Vec6<J>& y) const {
    return jets_.BushingDeflections(y);
  }

  // The effect hooks of SuspensionModel, on every evaluation it keeps.
  void SetProgressiveStiffness(
      const typename SuspensionModel<J>::StiffeningCoefficients& c) {
    typename SuspensionModel<double>::StiffeningCoefficients value;
    progressive_tangents_ = false;
    for (int t = 0; t < kStiffeningTerms; ++t) {
      for (int i = 0; i < kNumBushings; ++i) {
        value[t][i] = c[t][i].a;
        progressive_tangents_ = progressive_tangents_ || Carries(c[t][i]);
        hook_tangents_.stiffening[t].row(i) = c[t][i].v.transpose();
      }
    }
    values_.SetProgressiveStiffness(value);
    jets_.SetProgressiveStiffness(c);
  }
  void SetExtraBushingForce(
      const typename SuspensionModel<J>::ExtraBushingForce& extra) {
    typename SuspensionModel<double>::ExtraBushingForce value;
    extra_tangents_ = false;
    for (int i = 0; i < kNumBushings; ++i) {
      value.force[i] = extra.force[i].a;
      value.stiffness[i] = extra.stiffness[i].a;
      value.reference[i] = extra.reference[i].a;
      extra_tangents_ = extra_tangents_ || Carries(extra.force[i]) ||
                        Carries(extra.stiffness[i]) ||
                        Carries(extra.reference[i]);
      hook_tangents_.extra_force.row(i) = extra.force[i].v.transpose();
      hook_tangents_.extra_stiffness.row(i) = extra.stiffness[i].v.transpose();
      hook_tangents_.extra_reference.row(i) = extra.reference[i].v.transpose();
    }
    values_.SetExtraBushingForce(value);
    jets_.SetExtraBushingForce(extra);
  }

  // Static equilibrium Q(y, 0) = 0: Newton in double, then the tangents from
  // the implicit function theorem, dy = -(dQ/dy)^-1 (dQ/dp dp + dQ/dF dF).
  Status SolveEquilibrium(const RigLoad<J>& load, int max_iterations,
                          Vec6<J>* y) const {
    Vec6<double> y_value;
    const Status status = SolveStaticEquilibrium(values_, ValuesOf(load),
                                                 max_iterations, &y_value);
    if (!status.ok()) return status;
    GeneralizedForce<double> g;
    values_.Evaluate(ValuesOf(load), y_value, Vec6<double>::Zero(), true, &g);
    GeneralizedForce<J> g_jet;
    const Vec6<J> y_constant = Constants(y_value);
    jets_.Evaluate(load, y_constant, Constants(Vec6<double>::Zero()), false,
                   &g_jet);
    const Eigen::Matrix<double, 6, kDirections> dy =
        -Eigen::PartialPivLU<Mat6<double>>(g.dq_dy).solve(Tangents(g_jet.q));
    *y = WithTangents(y_value, dy);
    return Status::Ok();
  }

  // One step h under the load of t_{n+1}, state and tangents together. The
  // values are those of SemiImplicitEulerStep<double>, but for the pose
  // update's G^-1, whose values come from the Jet's (equal up to the last
  // bits: Ceres divides as a (1/b)).
  void Step(const RigLoad<J>& load_next, double h, ModelState<J>* state) const;

 private:
  static constexpr int kNumElements = SuspensionModel<double>::kNumElements;
  using Tangent6 = Eigen::Matrix<double, 6, kDirections>;

  // What one step's right-hand sides are built from: the predicted point
  // (values and tangents), w(dz) and its tangents, the load.
  struct StepPoint {
    Vec6<double> y_predicted;
    Vec6<double> z;
    Vec6<J> y_predicted_jet;
    Vec6<J> z_jet;
    Vec6<double> w;      // w(dz) = (h^2 V dz, h dz): pose part
    Vec3<J> w_rotation;  // h^2 G^-1(y) dz_rot with its tangents
    Vec6<double> dz;
    double h;
  };
  // Q's Jacobians at the predicted point, in double: those of the state
  // and of the linear parameters always, those of the hooks and load when
  // they carry tangents.
  struct PointJacobians {
    GeneralizedForce<double> force;
    typename SuspensionModel<double>::LinearParameterJacobian parameters;
    typename SuspensionModel<double>::HookAndLoadJacobian hooks;
    typename SuspensionModel<double>::PointState point;
    bool load_tangents = false;
    bool with_hooks = false;
  };
  // h dQ - dM dz + d(DQ[w]) for every direction (see the top of the file).
  Tangent6 RightHandSide(const StepPoint& point, const RigLoad<J>& load_jet,
                         const PointJacobians& values) const;
  Tangent6 MassTangentTimes(const Vec6<double>& dz) const {
    Tangent6 out;
    for (int k = 0; k < 3; ++k) out.row(k) = dz(k) * mass_tangents_;
    for (int k = 0; k < 3; ++k) {
      out.row(k + 3) = dz(k + 3) * inertia_tangents_.row(k);
    }
    return out;
  }
  // Whether any tangent is there at all: exactly zero, not Eigen's isZero
  // (|v| <= 1e-12), since the products skip what is absent, and a 1e-13 m
  // hard-point tangent times 1e6 N/m is not negligible. NaN carries (the
  // products then propagate it).
  template <typename Derived>
  static bool AnyTangent(const Eigen::MatrixBase<Derived>& tangents) {
    return (tangents.array() != 0.0).any();
  }
  static bool Carries(const J& x) { return AnyTangent(x.v); }
  static bool HasTangents(const RigLoad<J>& load) {
    for (int k = 0; k < 3; ++k) {
      if (Carries(load.force(k)) || Carries(load.point(k))) return true;
    }
    return false;
  }

  static SuspensionParameters<double> ValuesOf(
      const SuspensionParameters<J>& p) {
    SuspensionParameters<double> out;
    out.mass = p.mass.a;
    for (int k = 0; k < 3; ++k) out.inertia(k) = p.inertia(k).a;
    auto element = [](const AxialElement<J>& e) {
      AxialElement<double> value;
      for (int k = 0; k < 3; ++k) {
        value.carrier_point(k) = e.carrier_point(k).a;
        value.chassis_point(k) = e.chassis_point(k).a;
      }
      value.stiffness = e.stiffness.a;
      value.damping = e.damping.a;
      return value;
    };
    for (int i = 0; i < kNumBushings; ++i) {
      out.bushings[i] = element(p.bushings[i]);
    }
    out.spring = element(p.spring);
    return out;
  }
  static RigLoad<double> ValuesOf(const RigLoad<J>& load) {
    RigLoad<double> out;
    for (int k = 0; k < 3; ++k) {
      out.force(k) = load.force(k).a;
      out.point(k) = load.point(k).a;
    }
    return out;
  }
  static Vec6<J> Constants(const Vec6<double>& x) {
    Vec6<J> out;
    for (int k = 0; k < 6; ++k) out(k) = J(x(k));
    return out;
  }
  static Tangent6 Tangents(const Vec6<J>& x) {
    Tangent6 out;
    for (int k = 0; k < 6; ++k) out.row(k) = x(k).v.transpose();
    return out;
  }
  static Vec6<J> WithTangents(const Vec6<double>& value, const Tangent6& d) {
    Vec6<J> out;
    for (int k = 0; k < 6; ++k) out(k) = J(value(k), d.row(k).transpose());
    return out;
  }

  SuspensionModel<double> values_;
  SuspensionModel<J> jets_;
  // Whether the hooks carry tangents, and the tangents of the inputs: row i
  // the element's (bushings, then the spring-damper), the hooks' row i the
  // bushing's.
  bool progressive_tangents_ = false;
  bool extra_tangents_ = false;
  struct HookTangents {
    std::array<Eigen::Matrix<double, kNumBushings, kDirections>,
               kStiffeningTerms>
        stiffening;
    Eigen::Matrix<double, kNumBushings, kDirections> extra_force;
    Eigen::Matrix<double, kNumBushings, kDirections> extra_stiffness;
    Eigen::Matrix<double, kNumBushings, kDirections> extra_reference;
  } hook_tangents_;
  Eigen::Matrix<double, kNumElements, kDirections> stiffness_tangents_;
  Eigen::Matrix<double, kNumElements, kDirections> damping_tangents_;
  Eigen::Matrix<double, 1, kDirections> mass_tangents_;
  Eigen::Matrix<double, 3, kDirections> inertia_tangents_;
  // Per element: its chassis point's (rows 0-2) and carrier point's
  // (rows 3-5), as SuspensionModel::HardPointJacobian orders them.
  std::array<Tangent6, kNumElements> hard_point_tangents_;
  // Whether stiffness, damping or inertia carries a tangent (the
  // estimator's usual fit has
  // stiffnesses only: the other products are skipped).
  bool stiffness_carries_ = false;
  bool damping_carries_ = false;
  bool inertia_carries_ = false;
  // Whether each element's hard points carry a tangent (the right-hand side
  // then needs its hard-point Jacobian and that Jacobian's derivative).
  std::array<bool, kNumElements> hard_point_carries_{};
};

template <typename J>
void TangentLinearModel<J>::Step(const RigLoad<J>& load_next, double h,
                                 ModelState<J>* state) const {
  // The value step, exactly as SemiImplicitEulerStep<double> runs it.
  StepPoint point;
  point.h = h;
  for (int k = 0; k < 6; ++k) point.z(k) = state->z(k).a;
  Vec6<double> y;
  for (int k = 0; k < 6; ++k) y(k) = state->y(k).a;
  const Mat3<double> g_inv =
      InverseAngularRateMatrix<double>(y.template tail<3>());
  Vec6<double> y_rate;
  y_rate << point.z.template head<3>(), g_inv * point.z.template tail<3>();
  point.y_predicted = y + h * y_rate;
  const RigLoad<double> load = ValuesOf(load_next);
  PointJacobians values;
  values.load_tangents = HasTangents(load_next);
  values.with_hooks =
      progressive_tangents_ || extra_tangents_ || values.load_tangents;
  values_.Evaluate(load, point.y_predicted, point.z, true, &values.force,
                   &values.parameters,
                   values.with_hooks ? &values.hooks : nullptr, &values.point);
  const GeneralizedForce<double>& g = values.force;
  Mat6<double> iteration_matrix = values_.mass_matrix() - h * g.dq_dz;
  iteration_matrix.template leftCols<3>() -=
      (h * h) * g.dq_dy.template leftCols<3>();
  iteration_matrix.template rightCols<3>() -=
      (h * h) * (g.dq_dy.template rightCols<3>() * g_inv);
  const Eigen::PartialPivLU<Mat6<double>> lu(iteration_matrix);
  point.dz = lu.solve(h * g.q);

  // The tangents of the predicted pose and of w(dz) (through G^-1(y)).
  const Mat3<J> g_inv_jet =
      InverseAngularRateMatrix<J>(state->y.template tail<3>());
  Vec6<J> y_rate_jet;
  y_rate_jet << state->z.template head<3>(),
      g_inv_jet * state->z.template tail<3>();
  point.y_predicted_jet = state->y + y_rate_jet * h;
  point.z_jet = state->z;
  point.w_rotation = (g_inv_jet * point.dz.template tail<3>()) * (h * h);
  for (int k = 0; k < 3; ++k) {
    point.w(k) = h * h * point.dz(k);
    point.w(k + 3) = point.w_rotation(k).a;
  }

  Tangent6 d_dz = RightHandSide(point, load_next, values);
  // Column by column: Eigen's fixed-size vector solve is unrolled, its
  // matrix solve takes the blocked general path (a tenth of the step).
  for (int j = 0; j < kDirections; ++j) {
    d_dz.col(j) = lu.solve(d_dz.col(j).eval());
  }

  // z' = z + dz, y' = y + h V(y) z', in J arithmetic for y's tangents.
  for (int k = 0; k < 6; ++k) {
    state->z(k) =
        J(point.z(k) + point.dz(k), state->z(k).v + d_dz.row(k).transpose());
  }
  state->y.template head<3>() += state->z.template head<3>() * h;
  state->y.template tail<3>() += (g_inv_jet * state->z.template tail<3>()) * h;
}

template <typename J>
typename TangentLinearModel<J>::Tangent6 TangentLinearModel<J>::RightHandSide(
    const StepPoint& point, const RigLoad<J>& load_jet,
    const PointJacobians& values) const {
  const GeneralizedForce<double>& g = values.force;
  const auto& p = values.parameters;
  const auto& hook = values.hooks;
  typename SuspensionModel<double>::DerivativeRequest request;
  request.hooks = values.with_hooks;
  request.hard_points = hard_point_carries_;
  typename SuspensionModel<double>::JacobianDerivatives d;
  values_.DifferentiateJacobians(values.point, point.w, point.h * point.dz,
                                 request, &d);

  // h dQ + d(DQ[w]) = (h A + A') dx per Jacobian A and its derivative A'
  // along w: one product per Jacobian instead of two.
  const double h = point.h;
  Eigen::Matrix<double, 3, kDirections> d_w_rotation;
  for (int k = 0; k < 3; ++k) {
    d_w_rotation.row(k) = point.w_rotation(k).v.transpose();
  }
  Tangent6 rhs = -MassTangentTimes(point.dz);
  rhs.noalias() +=
      (h * g.dq_dy + d.dq_dy).lazyProduct(Tangents(point.y_predicted_jet));
  rhs.noalias() += (h * g.dq_dz + d.dq_dz).lazyProduct(Tangents(point.z_jet));
  rhs.noalias() += g.dq_dy.template rightCols<3>().lazyProduct(d_w_rotation);
  if (stiffness_carries_) {
    rhs.noalias() += (h * p.stiffness + d.parameters.stiffness)
                         .lazyProduct(stiffness_tangents_);
  }
  if (damping_carries_) {
    rhs.noalias() +=
        (h * p.damping + d.parameters.damping).lazyProduct(damping_tangents_);
  }
  if (inertia_carries_) {
    rhs.noalias() +=
        (h * p.inertia + d.parameters.inertia).lazyProduct(inertia_tangents_);
  }
  for (int i = 0; i < kNumElements; ++i) {
    if (!request.hard_points[i]) continue;
    rhs.noalias() +=
        (h * values_.HardPointJacobianOf(values.point, i) + d.hard_points[i])
            .lazyProduct(hard_point_tangents_[i]);
  }
  for (int t = 0; t < kStiffeningTerms && progressive_tangents_; ++t) {
    rhs.noalias() += (h * hook.stiffening[t] + d.hooks.stiffening[t])
                         .lazyProduct(hook_tangents_.stiffening[t]);
  }
  if (extra_tangents_) {
    rhs.noalias() += (h * hook.extra_force + d.hooks.extra_force)
                         .lazyProduct(hook_tangents_.extra_force);
    rhs.noalias() += (h * hook.extra_stiffness + d.hooks.extra_stiffness)
                         .lazyProduct(hook_tangents_.extra_stiffness);
    rhs.noalias() += (h * hook.extra_reference + d.hooks.extra_reference)
                         .lazyProduct(hook_tangents_.extra_reference);
  }
  if (values.load_tangents) {
    Eigen::Matrix<double, 3, kDirections> force_tangents, point_tangents;
    for (int k = 0; k < 3; ++k) {
      force_tangents.row(k) = load_jet.force(k).v.transpose();
      point_tangents.row(k) = load_jet.point(k).v.transpose();
    }
    rhs.noalias() +=
        (h * hook.load_force + d.hooks.load_force).lazyProduct(force_tangents);
    rhs.noalias() +=
        (h * hook.load_point + d.hooks.load_point).lazyProduct(point_tangents);
  }
  return rhs;
}

// The overloads SimulateTrajectory finds for a TangentLinearModel.
template <typename J>
Status SolveStaticEquilibrium(const TangentLinearModel<J>& model,
                              const RigLoad<J>& load, int max_iterations,
                              Vec6<J>* y) {
  return model.SolveEquilibrium(load, max_iterations, y);
}
template <typename J>
void SemiImplicitEulerStep(const TangentLinearModel<J>& model,
                           const RigLoad<J>& load_next, double h,
                           ModelState<J>* state) {
  model.Step(load_next, h, state);
}

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_TANGENT_LINEAR_H_
