// The paper's semi-implicit Euler with constant step h (section 2):
//   (M - h dQ/dz - h^2 dQ/dy V_n)(z_{n+1} - z_n) = h Q(y_n + h V_n z_n, z_n),
//   y_{n+1} = y_n + h V_n z_{n+1},
// with Q and its partial derivatives evaluated at (y_n + h V_n z_n, z_n) and
// the rig load of t_{n+1}. One linear 6x6 solve per step, no iteration, no
// allocation: this is the step the real-time loop runs.
#ifndef KCRIG_RT_CORE_MODEL_SEMI_IMPLICIT_EULER_H_
#define KCRIG_RT_CORE_MODEL_SEMI_IMPLICIT_EULER_H_

#include "Eigen/LU"
#include "rt_core/model/suspension_model.h"

namespace kcrig {

template <typename T>
void SemiImplicitEulerStep(const SuspensionModel<T>& model,
                           const RigLoad<T>& load_next, double h,
                           ModelState<T>* state) {
  // V = diag(I, G^-1): only the rotational block is ever multiplied out.
  const Mat3<T> g_inv =
      InverseAngularRateMatrix<T>(state->y.template tail<3>());
  Vec6<T> y_rate;
  y_rate << state->z.template head<3>(), g_inv * state->z.template tail<3>();
  const Vec6<T> y_predicted = state->y + h * y_rate;
  GeneralizedForce<T> g;
  model.Evaluate(load_next, y_predicted, state->z, /*with_jacobians=*/true, &g);
  Mat6<T> iteration_matrix = model.mass_matrix() - h * g.dq_dz;
  iteration_matrix.template leftCols<3>() -=
      (h * h) * g.dq_dy.template leftCols<3>();
  iteration_matrix.template rightCols<3>() -=
      (h * h) * (g.dq_dy.template rightCols<3>() * g_inv);
  const Vec6<T> dz =
      Eigen::PartialPivLU<Mat6<T>>(iteration_matrix).solve(h * g.q);
  state->z += dz;
  state->y.template head<3>() += h * state->z.template head<3>();
  state->y.template tail<3>() += h * (g_inv * state->z.template tail<3>());
}

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_SEMI_IMPLICIT_EULER_H_
