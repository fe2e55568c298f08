// Profile likelihood: identifiability beyond the linearization. Each
// estimated parameter is held at values stepping away from its estimate
// while the others are re-optimized; the profile is
//   delta_chi2(v) = 2 (cost(v) - cost_min)
// in the weighted residuals of eq. (6), i.e. against the stated sensor
// sigmas. Where it crosses the chi-square threshold (3.84 for 95 %, one
// degree of freedom) are the ends of the profile-likelihood interval.
#ifndef KCRIG_ESTIMATOR_PROFILE_LIKELIHOOD_H_
#define KCRIG_ESTIMATOR_PROFILE_LIKELIHOOD_H_

#include <string>
#include <vector>

#include "estimator/estimator.h"

namespace kcrig {

enum class Identifiability {
  kIdentifiable,     // the interval closes within the practical width
  kPracticallyNot,   // the profile rises, but too slowly or one-sided
  kStructurallyNot,  // the profile is flat: the data cannot see it
};

const char* IdentifiabilityName(Identifiability identifiability);

struct ProfileOptions {
  // Threshold on delta_chi2: the 95 % quantile of chi-square with 1 dof.
  double threshold = 3.841458820694124;
  // The interval must close within this relative distance of the estimate
  // on both sides; 1.96 x the estimator's max_relative_standard_error keeps
  // the profile's verdict consistent with the linearized one.
  double practical_half_width = 0.196;
  // The profile is explored up to this relative distance (or the scale
  // bounds), in geometrically growing steps.
  double explored_half_width = 0.5;
  // First step, relative to the estimate; it doubles up to the explored
  // width.
  double first_step = 0.01;
  // A profile that never rises above this fraction of the threshold over the
  // explored range is flat: structurally not identifiable.
  double flat_fraction = 1e-3;
};

struct ParameterProfile {
  std::string name;
  std::vector<double> values;      // physical units, increasing
  std::vector<double> delta_chi2;  // at each value
  // Profile-likelihood 95 % interval ends; NaN where the profile does not
  // cross the threshold within the explored range.
  double lower = 0, upper = 0;
  Identifiability identifiability = Identifiability::kIdentifiable;
};

// Classifies one profile (values relative to the estimate, i.e. v/v_hat-1).
Identifiability ClassifyProfile(const std::vector<double>& relative_values,
                                const std::vector<double>& delta_chi2,
                                const ProfileOptions& options);

// Profiles every parameter of `fit` (the result of Estimate with the same
// experiments and options).
Status ProfileLikelihood(const SuspensionParameters<double>& nominal,
                         const std::vector<Experiment>& experiments,
                         const EstimatorOptions& options,
                         const EstimationResult& fit, double integrator_step,
                         const ProfileOptions& profile_options,
                         std::vector<ParameterProfile>* profiles);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_PROFILE_LIKELIHOOD_H_
