// Offline trajectories of the model: static equilibrium for the initial state,
// then the semi-implicit Euler over the whole excitation, sampled at a fixed
// rate. Templated: with ceres::Jet parameters the samples carry the exact
// discrete sensitivities dx(t_j)/dp of the integrator's own solution.
#ifndef KCRIG_RT_CORE_MODEL_SIMULATION_H_
#define KCRIG_RT_CORE_MODEL_SIMULATION_H_

#include <cmath>
#include <string>
#include <vector>

#include "Eigen/LU"
#include "base/status.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/semi_implicit_euler.h"
#include "rt_core/model/suspension_model.h"

namespace kcrig {

struct SimulationOptions {
  // Integrator step h [s].
  double step = 1e-3;
  // One output sample every this many steps (sample period = step * this).
  int steps_per_sample = 1;
  // Newton iterations allowed for the initial static equilibrium.
  int max_equilibrium_iterations = 50;
  // A displacement beyond this [m], or an angle beyond this [rad], means the
  // integration has diverged: the model describes small K&C deflections.
  double divergence_limit = 0.5;
};

template <typename T>
struct TrajectorySample {
  double t = 0;                     // [s]
  Vec3<T> force = Vec3<T>::Zero();  // rig force on the wheel [N]
  Vec6<T> y = Vec6<T>::Zero();      // x, y, z [m], toe, camber, caster [rad]
};

// Newton's method on Q(y, 0) = 0 from the design position. With Jet scalars
// the derivative parts converge with the values; two extra iterations after
// the value has converged make sure they have.
template <typename T>
Status SolveStaticEquilibrium(const SuspensionModel<T>& model,
                              const RigLoad<T>& load, int max_iterations,
                              Vec6<T>* y) {
  y->setZero();
  const Vec6<T> z = Vec6<T>::Zero();
  GeneralizedForce<T> g;
  int converged_iterations = 0;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    model.Evaluate(load, *y, z, /*with_jacobians=*/true, &g);
    const Vec6<T> dy = -Eigen::PartialPivLU<Mat6<T>>(g.dq_dy).solve(g.q);
    double step_norm = 0;
    for (int k = 0; k < 6; ++k) {
      const double value = ValueOf(dy(k));
      if (!std::isfinite(value)) {
        return Status::Error(
            "static equilibrium: singular stiffness (a link or the spring "
            "gives no support in some direction)");
      }
      step_norm = std::max(step_norm, std::abs(value));
    }
    *y += dy;
    if (step_norm < 1e-14) {
      if (++converged_iterations > 2) return Status::Ok();
    }
  }
  return Status::Error("static equilibrium: Newton did not converge in " +
                       std::to_string(max_iterations) + " iterations");
}

// The number of whole sample periods in the excitation (samples - 1).
template <typename Excitation>
long NumSampleIntervals(const Excitation& excitation,
                        const SimulationOptions& options) {
  const double sample_period = options.step * options.steps_per_sample;
  return std::lround(std::floor(excitation.EndTime() / sample_period + 1e-9));
}

// Integrates over [0, excitation.EndTime()] starting from the static
// equilibrium under the load at t = 0 (the rig has settled at -Fmax before
// the logged ramp starts). Writes one sample at t = 0 and one every
// steps_per_sample steps after.
//
// `Model` is SuspensionModel<T> (double, or Jets: the reference
// sensitivities) or TangentLinearModel<Jet> (the same sensitivities, fast);
// `Excitation` is RampExcitation<T> or anything else with
// `double EndTime() const` and `RigLoad<T> LoadAt(double t) const`.
// `visit(const TrajectorySample<T>&)` gets each sample as it is computed, so
// a long log's trajectory with sensitivities is never held whole.
template <typename Model, typename Excitation, typename Visit,
          typename T = typename Model::Scalar>
Status VisitTrajectory(const Model& model, const Excitation& excitation,
                       const SimulationOptions& options, Visit&& visit) {
  if (!(options.step > 0) || options.steps_per_sample < 1) {
    return Status::Error(
        "simulation: step must be > 0 s and steps_per_sample >= 1");
  }
  if (!(excitation.EndTime() > 0)) {
    return Status::Error("simulation: excitation duration must be > 0 s");
  }
  const long num_intervals = NumSampleIntervals(excitation, options);

  ModelState<T> state;
  const Status equilibrium =
      SolveStaticEquilibrium(model, excitation.LoadAt(0.0),
                             options.max_equilibrium_iterations, &state.y);
  if (!equilibrium.ok()) return equilibrium;

  visit(TrajectorySample<T>{0.0, excitation.LoadAt(0.0).force, state.y});
  long step_index = 0;
  for (long j = 1; j <= num_intervals; ++j) {
    for (int s = 0; s < options.steps_per_sample; ++s) {
      ++step_index;
      SemiImplicitEulerStep(model, excitation.LoadAt(step_index * options.step),
                            options.step, &state);
    }
    const double t = step_index * options.step;
    for (int k = 0; k < 6; ++k) {
      const double value = ValueOf(state.y(k));
      if (!std::isfinite(value) || std::abs(value) > options.divergence_limit) {
        return Status::Error("simulation diverged at t = " + std::to_string(t) +
                             " s (state beyond the model's range)");
      }
    }
    visit(TrajectorySample<T>{t, excitation.LoadAt(t).force, state.y});
  }
  return Status::Ok();
}

// VisitTrajectory into `samples` (cleared first).
template <typename Model, typename Excitation,
          typename T = typename Model::Scalar>
Status SimulateTrajectory(const Model& model, const Excitation& excitation,
                          const SimulationOptions& options,
                          std::vector<TrajectorySample<T>>* samples) {
  samples->clear();
  if (options.step > 0 && options.steps_per_sample >= 1 &&
      excitation.EndTime() > 0) {
    samples->reserve(NumSampleIntervals(excitation, options) + 1);
  }
  return VisitTrajectory(model, excitation, options,
                         [samples](const TrajectorySample<T>& sample) {
                           samples->push_back(sample);
                         });
}

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_SIMULATION_H_
