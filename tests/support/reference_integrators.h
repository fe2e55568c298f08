// Integrators the tests and benchmarks compare the semi-implicit Euler with:
// SUNDIALS CVODE (BDF, dense Newton) at tight tolerance as the reference
// solution, and explicit Euler to show what the stiff system does to a
// non-implicit method.
#ifndef KCRIG_TESTS_SUPPORT_REFERENCE_INTEGRATORS_H_
#define KCRIG_TESTS_SUPPORT_REFERENCE_INTEGRATORS_H_

#include <functional>
#include <vector>

#include "base/status.h"
#include "rt_core/model/suspension_model.h"

namespace kcrig {

struct CvodeOptions {
  double relative_tolerance = 1e-10;
  // Absolute tolerances on positions [m] / angles [rad] and on velocities.
  double absolute_tolerance_position = 1e-13;
  double absolute_tolerance_velocity = 1e-10;
};

struct CvodeResult {
  std::vector<Vec6<double>> y;  // at each requested time
  long rhs_evaluations = 0;
  long steps = 0;
};

using LoadFunction = std::function<RigLoad<double>(double t)>;

// Integrates dy/dt = V(y) z, M dz/dt = Q(y, z) under the rig load `load(t)`
// from the state `initial` at t = 0 and reports y at each of `times`
// (increasing, > 0).
Status IntegrateWithCvode(const SuspensionModel<double>& model,
                          const LoadFunction& load,
                          const ModelState<double>& initial,
                          const std::vector<double>& times,
                          const CvodeOptions& options, CvodeResult* result);

// One explicit (forward) Euler step with the rig load of t_n.
void ExplicitEulerStep(const SuspensionModel<double>& model,
                       const RigLoad<double>& load, double h,
                       ModelState<double>* state);

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_REFERENCE_INTEGRATORS_H_
