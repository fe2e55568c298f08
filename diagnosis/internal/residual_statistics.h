// The residual statistics of the diagnosis: the score of weighted residuals
// against the noise floor and lagged correlation (the chi-square and
// whiteness tests are the estimator's adequacy tests, the weighted residuals
// of a candidate effect_model.h's).
#ifndef KCRIG_DIAGNOSIS_INTERNAL_RESIDUAL_STATISTICS_H_
#define KCRIG_DIAGNOSIS_INTERNAL_RESIDUAL_STATISTICS_H_

#include <vector>

#include "base/status.h"
#include "estimator/adequacy.h"
#include "estimator/effect_model.h"
#include "estimator/experiment.h"

namespace kcrig {

// Accumulates the mean squared weighted residual and the per-channel RMS
// [m, rad] over several logs.
struct ScoreSum {
  double sum = 0;
  Vec6<double> channel_sum = Vec6<double>::Zero();  // sum of r^2 [SI^2]
  long samples = 0;
  void Add(const Experiment& e, const std::vector<Vec6<double>>& w) {
    for (size_t j = 0; j < w.size(); ++j) {
      if (!Observed(e, j)) continue;
      sum += w[j].squaredNorm();
      channel_sum += w[j].cwiseProduct(e.sigma).cwiseAbs2();
      ++samples;
    }
  }
  double Score() const { return samples > 0 ? sum / (6.0 * samples) : 0; }
  Vec6<double> Rms() const {
    return samples > 0 ? Vec6<double>((channel_sum / samples).cwiseSqrt())
                       : Vec6<double>::Zero();
  }
};

// Pearson correlation of a[j] with b[j - lag] over the overlap.
double LaggedCorrelation(const std::vector<double>& a,
                         const std::vector<double>& b, int lag);

}  // namespace kcrig

#endif  // KCRIG_DIAGNOSIS_INTERNAL_RESIDUAL_STATISTICS_H_
