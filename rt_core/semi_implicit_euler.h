// The paper's semi-implicit Euler with constant step h (section 2):
//   (M - h dQ/dz - h^2 dQ/dy V_n)(z_{n+1} - z_n) = h Q(y_n + h V_n z_n, z_n),
//   y_{n+1} = y_n + h V_n z_{n+1},
// with Q and its partial derivatives evaluated at (y_n + h V_n z_n, z_n) and
// the rig load of t_{n+1}. One linear 6x6 solve per step, no iteration, no
// allocation: this is the step the real-time loop runs.
#ifndef KCRIG_RT_CORE_SEMI_IMPLICIT_EULER_H_
#define KCRIG_RT_CORE_SEMI_IMPLICIT_EULER_H_

#include "Eigen/LU"
#include "rt_core/suspension_model.h"

namespace kcrig {

template <typename T>
void SemiImplicitEulerStep(const SuspensionModel<T>& model,
                           const RigLoad<T>& load_next, double h,
                           ModelState<T>* state) {
  const Mat6<T> v = model.KinematicMatrix(state->y);
  const Vec6<T> y_predicted = state->y + h * (v * state->z);
  GeneralizedForce<T> g;
  model.Evaluate(load_next, y_predicted, state->z, /*with_jacobians=*/true, &g);
  const Mat6<T> iteration_matrix =
      model.mass_matrix() - h * g.dq_dz - (h * h) * (g.dq_dy * v);
  const Vec6<T> dz =
      Eigen::PartialPivLU<Mat6<T>>(iteration_matrix).solve(h * g.q);
  state->z += dz;
  state->y += h * (v * state->z);
}

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_SEMI_IMPLICIT_EULER_H_
