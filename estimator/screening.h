// Screening of candidate parameters (paper section 3.2): which parameters
// move the objective r(p) of eq. (6) at all, which ones depend on each
// other, and which subset can be estimated from the data.
//
//  - Impact: Morris elementary effects of r over the candidates' ranges,
//    on a grid of `levels` log-spaced levels per parameter, `trajectories`
//    one-at-a-time trajectories (Morris 1991; mu* of Campolongo et al.).
//  - Dependence: correlation of the sensitivity columns dr_j/dp_i at the
//    nominal values; |corr| above a threshold flags a pair.
//  - Estimable subset: column-pivoted QR on the weighted Jacobian at the
//    nominal values, keeping the largest leading set whose linearized
//    standard errors (at the stated sensor sigmas) all stay within the
//    estimator's practical limit, negligible parameters excluded.
#ifndef KCRIG_ESTIMATOR_SCREENING_H_
#define KCRIG_ESTIMATOR_SCREENING_H_

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "Eigen/Core"
#include "base/iteration_callback.h"
#include "estimator/estimator.h"

namespace kcrig {

struct ScreeningOptions {
  // Candidates, by name; default the five bushing stiffnesses.
  std::vector<std::string> parameters = {"c_O1", "c_O2", "c_V1", "c_V2", "c_P"};
  // Range of every candidate as multiples of its nominal value.
  double range_low = 0.5;
  double range_high = 2.0;
  // Morris design: grid levels per parameter and number of trajectories.
  int levels = 4;
  int trajectories = 20;
  std::uint64_t seed = 1;
  // mu* below this fraction of the largest mu* is negligible.
  double negligible_fraction = 0.01;
  // Sensitivity columns correlated beyond this are mutually dependent.
  double dependence_correlation = 0.95;
  // Asked after each trajectory with the model evaluations done and in all
  // (stage "screening"); kAbort stops it with Interrupted(). Optional.
  // (The estimator options' callback is not used: screening solves
  // nothing.)
  IterationCallback callback;
};

struct ScreenedParameter {
  std::string name;
  double mu_star = 0;  // mean |elementary effect| of r, per unit log-range
  double mu = 0;       // mean elementary effect
  double sigma = 0;    // standard deviation: nonlinearity or interaction
  bool negligible = false;
};

struct ScreeningResult {
  std::vector<ScreenedParameter> ranking;   // by mu*, largest first
  std::vector<std::string> names;           // candidates in the given order
  Eigen::MatrixXd sensitivity_correlation;  // in `names` order
  std::vector<std::pair<std::string, std::string>> dependent_pairs;
  std::vector<std::string> estimable;  // proposed subset
  int evaluations = 0;
  double seconds = 0;
};

Status Screen(const SuspensionParameters<double>& nominal,
              const std::vector<Experiment>& experiments,
              const EstimatorOptions& estimator_options,
              const ScreeningOptions& options, double integrator_step,
              ScreeningResult* result);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_SCREENING_H_
