// Noise level of a computed function, by the ECnoise procedure of Moré and
// Wild ("Estimating computational noise", SIAM J. Sci. Comput. 33, 2011):
// the k-th differences of samples along a line, scaled so that for
// independent noise their mean square is the noise variance, are compared
// across orders; where consecutive orders agree (within a factor 4) and
// change sign, that level is the noise.
#ifndef KCRIG_DESIGNER_INTERNAL_ECNOISE_H_
#define KCRIG_DESIGNER_INTERNAL_ECNOISE_H_

#include <functional>
#include <string>
#include <vector>

namespace kcrig {

enum class NoiseVerdict {
  kEstimated,        // `noise` holds the estimate
  kSpacingTooSmall,  // all samples equal: no noise visible at this spacing
  kSpacingTooLarge,  // the smooth part dominates the differences
};

struct NoiseEstimate {
  NoiseVerdict verdict = NoiseVerdict::kSpacingTooLarge;
  double noise = 0;           // absolute, in the function's units
  double relative_noise = 0;  // noise / |f(centre)|
  double spacing = 0;         // the spacing of the samples used
};

// ECnoise on `values` sampled at equal spacing (at least 4 samples; 7-9
// are usual).
NoiseEstimate EstimateNoise(const std::vector<double>& values);

// Samples f(t) at t = (i - (n-1)/2) h, i = 0 .. n-1, and runs
// EstimateNoise, adapting h by factors of 100 from `initial_spacing` when
// the spacing is too small or too large (at most `max_tries` rounds).
NoiseEstimate EstimateNoiseAlongLine(const std::function<double(double)>& f,
                                     double initial_spacing,
                                     int num_samples = 9, int max_tries = 6);

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_INTERNAL_ECNOISE_H_
