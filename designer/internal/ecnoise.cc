#include "designer/internal/ecnoise.h"

#include <algorithm>
#include <cmath>

namespace kcrig {

NoiseEstimate EstimateNoise(const std::vector<double>& samples) {
  NoiseEstimate estimate;
  const int n = static_cast<int>(samples.size());
  if (n < 4) return estimate;
  const auto [min_it, max_it] =
      std::minmax_element(samples.begin(), samples.end());
  const double scale = std::max(std::abs(*min_it), std::abs(*max_it));
  // Samples spread by more than 10 %: the spacing is far too large.
  if (*max_it - *min_it > 0.1 * scale) return estimate;

  std::vector<double> d = samples;
  std::vector<double> level(n - 1, 0.0);
  std::vector<bool> sign_change(n - 1, false);
  double gamma = 1.0;
  for (int j = 1; j < n; ++j) {
    for (int i = 0; i < n - j; ++i) d[i] = d[i + 1] - d[i];
    if (j == 1 && std::all_of(d.begin(), d.begin() + (n - 1),
                              [](double v) { return v == 0.0; })) {
      estimate.verdict = NoiseVerdict::kSpacingTooSmall;
      return estimate;
    }
    // gamma_j = (j!)^2 / (2j)!: makes gamma_j E[(Delta^j e)^2] = var(e).
    gamma *= 0.5 * j / (2.0 * j - 1.0);
    double mean_square = 0, lo = d[0], hi = d[0];
    for (int i = 0; i < n - j; ++i) {
      mean_square += d[i] * d[i];
      lo = std::min(lo, d[i]);
      hi = std::max(hi, d[i]);
    }
    level[j - 1] = std::sqrt(gamma * mean_square / (n - j));
    sign_change[j - 1] = lo * hi < 0;
  }
  for (int k = 0; k + 2 < n - 1; ++k) {
    const double lo = std::min({level[k], level[k + 1], level[k + 2]});
    const double hi = std::max({level[k], level[k + 1], level[k + 2]});
    if (hi <= 4 * lo && sign_change[k]) {
      estimate.verdict = NoiseVerdict::kEstimated;
      estimate.noise = level[k];
      const double centre = std::abs(samples[n / 2]);
      estimate.relative_noise = centre > 0 ? level[k] / centre : 0;
      return estimate;
    }
  }
  return estimate;  // spacing too large
}

NoiseEstimate EstimateNoiseAlongLine(const std::function<double(double)>& f,
                                     double initial_spacing, int num_samples,
                                     int max_tries) {
  double h = initial_spacing;
  NoiseEstimate estimate;
  for (int attempt = 0; attempt < max_tries; ++attempt) {
    std::vector<double> values;
    for (int i = 0; i < num_samples; ++i) {
      values.push_back(f((i - 0.5 * (num_samples - 1)) * h));
    }
    estimate = EstimateNoise(values);
    estimate.spacing = h;
    if (estimate.verdict == NoiseVerdict::kEstimated) return estimate;
    h *= estimate.verdict == NoiseVerdict::kSpacingTooSmall ? 100.0 : 0.01;
  }
  return estimate;
}

}  // namespace kcrig
