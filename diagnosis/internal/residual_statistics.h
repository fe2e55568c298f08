// The residual statistics of the diagnosis: weighted residuals of a
// candidate model, their score against the noise floor, the chi-square tail,
// Ljung-Box whiteness and lagged correlation.
#ifndef KCRIG_DIAGNOSIS_INTERNAL_RESIDUAL_STATISTICS_H_
#define KCRIG_DIAGNOSIS_INTERNAL_RESIDUAL_STATISTICS_H_

#include <vector>

#include "base/status.h"
#include "diagnosis/effect_model.h"
#include "estimator/experiment.h"

namespace kcrig {

// Weighted residuals (sensed - measured) / sigma per sample (zero where
// not observed) of a model at `values`.
Status WeightedResiduals(const EffectModel& model,
                         const std::vector<double>& values, const Experiment& e,
                         double step, std::vector<Vec6<double>>* weighted);

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

// Ljung-Box Q of one channel's residual over the observed samples.
double LjungBox(const std::vector<double>& x, int lags);

// Whether residuals are white: the smallest Ljung-Box p-value over the
// channels of all logs, Bonferroni-corrected for their number.
double WhitenessP(const std::vector<Experiment>& logs,
                  const std::vector<std::vector<Vec6<double>>>& residuals,
                  int lags);

// Pearson correlation of a[j] with b[j - lag] over the overlap.
double LaggedCorrelation(const std::vector<double>& a,
                         const std::vector<double>& b, int lag);

// P(chi-square with `dof` degrees of freedom > x): the regularized upper
// incomplete gamma Q(dof/2, x/2).
double ChiSquareUpperTail(double x, double dof);

}  // namespace kcrig

#endif  // KCRIG_DIAGNOSIS_INTERNAL_RESIDUAL_STATISTICS_H_
