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
// parameters and G^-1(y)). One evaluation of Q in Dual<J> scalars gives Q,
// its N directional derivatives dQ, DQ[w] and the N mixed second derivatives
// d(DQ[w]) at once; W is factored once in double and solves all N
// directions. The state then moves as in the step, in J arithmetic.
//
// J is a Jet of N directions (value .a, derivatives .v, e.g. ceres::Jet):
// the same type the Jet reference uses, so the two are interchangeable.
#ifndef KCRIG_RT_CORE_MODEL_TANGENT_LINEAR_H_
#define KCRIG_RT_CORE_MODEL_TANGENT_LINEAR_H_

#include <string>

#include "Eigen/LU"
#include "base/status.h"
#include "rt_core/model/dual.h"
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
      : values_(ValuesOf(parameters)),
        jets_(parameters),
        second_(Lift(parameters)) {}

  // The model in J scalars: geometry queries (BushingDeflections, ...).
  const SuspensionModel<J>& jets() const { return jets_; }

  // The effect hooks of SuspensionModel, on all three evaluations.
  void SetProgressiveStiffness(const J& cubic_stiffness) {
    values_.SetProgressiveStiffness(cubic_stiffness.a);
    jets_.SetProgressiveStiffness(cubic_stiffness);
    second_.SetProgressiveStiffness(Second(cubic_stiffness, J(0.0)));
  }
  void SetExtraBushingForce(
      const typename SuspensionModel<J>::ExtraBushingForce& extra) {
    typename SuspensionModel<double>::ExtraBushingForce value;
    typename SuspensionModel<Second>::ExtraBushingForce second;
    for (int i = 0; i < kNumBushings; ++i) {
      value.force[i] = extra.force[i].a;
      value.stiffness[i] = extra.stiffness[i].a;
      value.reference[i] = extra.reference[i].a;
      second.force[i] = Second(extra.force[i], J(0.0));
      second.stiffness[i] = Second(extra.stiffness[i], J(0.0));
      second.reference[i] = Second(extra.reference[i], J(0.0));
    }
    values_.SetExtraBushingForce(value);
    jets_.SetExtraBushingForce(extra);
    second_.SetExtraBushingForce(second);
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
  // values are those of SemiImplicitEulerStep<double>.
  void Step(const RigLoad<J>& load_next, double h, ModelState<J>* state) const;

 private:
  using Second = Dual<J>;
  using Tangent6 = Eigen::Matrix<double, 6, kDirections>;

  // Every parameter of `p` mapped by `f`.
  template <typename U, typename F>
  static SuspensionParameters<U> Mapped(const SuspensionParameters<J>& p, F f) {
    SuspensionParameters<U> out;
    out.mass = f(p.mass);
    for (int k = 0; k < 3; ++k) out.inertia(k) = f(p.inertia(k));
    auto element = [&](const AxialElement<J>& e) {
      AxialElement<U> mapped;
      for (int k = 0; k < 3; ++k) {
        mapped.carrier_point(k) = f(e.carrier_point(k));
        mapped.chassis_point(k) = f(e.chassis_point(k));
      }
      mapped.stiffness = f(e.stiffness);
      mapped.damping = f(e.damping);
      return mapped;
    };
    for (int i = 0; i < kNumBushings; ++i) {
      out.bushings[i] = element(p.bushings[i]);
    }
    out.spring = element(p.spring);
    return out;
  }
  static SuspensionParameters<double> ValuesOf(
      const SuspensionParameters<J>& p) {
    return Mapped<double>(p, [](const J& x) { return x.a; });
  }
  static SuspensionParameters<Second> Lift(const SuspensionParameters<J>& p) {
    return Mapped<Second>(p, [](const J& x) { return Second(x, J(0.0)); });
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
  SuspensionModel<Second> second_;
};

template <typename J>
void TangentLinearModel<J>::Step(const RigLoad<J>& load_next, double h,
                                 ModelState<J>* state) const {
  // The value step, exactly as SemiImplicitEulerStep<double> runs it.
  ModelState<double> value;
  for (int k = 0; k < 6; ++k) {
    value.y(k) = state->y(k).a;
    value.z(k) = state->z(k).a;
  }
  const Mat3<double> g_inv =
      InverseAngularRateMatrix<double>(value.y.template tail<3>());
  Vec6<double> y_rate;
  y_rate << value.z.template head<3>(), g_inv * value.z.template tail<3>();
  const Vec6<double> y_predicted = value.y + h * y_rate;
  GeneralizedForce<double> g;
  values_.Evaluate(ValuesOf(load_next), y_predicted, value.z, true, &g);
  Mat6<double> iteration_matrix = values_.mass_matrix() - h * g.dq_dz;
  iteration_matrix.template leftCols<3>() -=
      (h * h) * g.dq_dy.template leftCols<3>();
  iteration_matrix.template rightCols<3>() -=
      (h * h) * (g.dq_dy.template rightCols<3>() * g_inv);
  const Eigen::PartialPivLU<Mat6<double>> lu(iteration_matrix);
  const Vec6<double> dz = lu.solve(h * g.q);

  // The tangents of the predicted pose and of w(dz) (through G^-1(y)).
  const J jet_h(h);
  const Mat3<J> g_inv_jet =
      InverseAngularRateMatrix<J>(state->y.template tail<3>());
  Vec6<J> y_rate_jet;
  y_rate_jet << state->z.template head<3>(),
      g_inv_jet * state->z.template tail<3>();
  const Vec6<J> y_predicted_jet = state->y + y_rate_jet * jet_h;
  const Vec3<J> dz_rot = Constants(dz).template tail<3>();
  const Vec3<J> w_rot = (g_inv_jet * dz_rot) * J(h * h);

  Vec6<Second> y_second;
  Vec6<Second> z_second;
  for (int k = 0; k < 3; ++k) {
    y_second(k) = Second(y_predicted_jet(k), J(h * h * dz(k)));
    y_second(k + 3) = Second(y_predicted_jet(k + 3), w_rot(k));
  }
  for (int k = 0; k < 6; ++k) z_second(k) = Second(state->z(k), J(h * dz(k)));
  RigLoad<Second> load_second;
  for (int k = 0; k < 3; ++k) {
    load_second.force(k) = Second(load_next.force(k), J(0.0));
    load_second.point(k) = Second(load_next.point(k), J(0.0));
  }
  GeneralizedForce<Second> g_second;
  second_.Evaluate(load_second, y_second, z_second, false, &g_second);

  // W d(dz) = h dQ - dM dz + d(DQ[w]), all directions in one solve.
  Tangent6 rhs;
  for (int k = 0; k < 6; ++k) {
    const Second& q = g_second.q(k);
    rhs.row(k) = (h * q.a.v - dz(k) * second_.mass_matrix()(k, k).a.v + q.e.v)
                     .transpose();
  }
  const Tangent6 d_dz = lu.solve(rhs);

  // z' = z + dz, y' = y + h V(y) z', in J arithmetic for y's tangents.
  for (int k = 0; k < 6; ++k) {
    state->z(k) =
        J(value.z(k) + dz(k), state->z(k).v + d_dz.row(k).transpose());
  }
  state->y.template head<3>() += state->z.template head<3>() * jet_h;
  state->y.template tail<3>() +=
      (g_inv_jet * state->z.template tail<3>()) * jet_h;
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
