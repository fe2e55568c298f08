#include "diagnosis/internal/localisation.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numeric>

#include "diagnosis/internal/residual_statistics.h"
#include "rt_core/model/channels.h"
#include "unsupported/Eigen/FFT"

namespace kcrig {
namespace {

// A log's force along its main direction in the x-y plane, its magnitude
// and the magnitude's rate (central difference over +-10 ms), per sample.
struct ForceHistory {
  std::vector<double> along, magnitude, rate;
  double peak_magnitude = 1;  // [N], at least 1
  double fastest_rate = 0;    // [N/s]
};

ForceHistory HistoryOf(const Experiment& e, size_t n) {
  Eigen::Vector2d direction_xy = Eigen::Vector2d::Zero();
  double peak = 0;
  for (const Vec3<double>& f : e.forces) {
    if (f.head<2>().norm() > peak) {
      peak = f.head<2>().norm();
      direction_xy = f.head<2>() / peak;
    }
  }
  ForceHistory h;
  h.along.resize(n);
  h.magnitude.resize(n);
  h.rate.resize(n);
  for (size_t j = 0; j < n; ++j) {
    h.along[j] = e.forces[j].head<2>().dot(direction_xy);
    h.magnitude[j] = e.forces[j].norm();
  }
  const size_t half = std::max<size_t>(
      1, static_cast<size_t>(std::lround(0.01 / e.sample_period)));
  for (size_t j = 0; j < n; ++j) {
    const size_t a = j >= half ? j - half : 0, b = std::min(n - 1, j + half);
    h.rate[j] =
        b > a ? (h.magnitude[b] - h.magnitude[a]) / ((b - a) * e.sample_period)
              : 0;
  }
  h.peak_magnitude =
      std::max(1.0, *std::max_element(h.magnitude.begin(), h.magnitude.end()));
  for (double r : h.rate)
    h.fastest_rate = std::max(h.fastest_rate, std::abs(r));
  return h;
}

void AddToSlice(const Vec6<double>& w, const Vec6<double>& r, GapSlice* s) {
  s->samples += 1;
  s->channel_score += w.cwiseAbs2();
  s->mean += r;
  s->rms += r.cwiseAbs2();
}

// Per-sample sums to means, rms and the share of the total excess.
void FinishSlice(double total_excess, GapSlice* s) {
  if (s->samples == 0) return;
  s->excess_share =
      total_excess != 0
          ? (s->channel_score.sum() - 6.0 * s->samples) / total_excess
          : 0;
  s->channel_score /= s->samples;
  s->mean /= s->samples;
  s->rms = (s->rms / s->samples).cwiseSqrt();
  s->score = s->channel_score.mean();
}

// A channel's slice keeps only its own channel's figures.
void FinishChannelSlice(double total_excess, int k, GapSlice* s) {
  s->excess_share =
      total_excess != 0 ? (s->channel_score(k) - s->samples) / total_excess : 0;
  s->score = s->samples > 0 ? s->channel_score(k) / s->samples : 0;
  s->mean(k) /= std::max(1, s->samples);
  s->rms(k) = std::sqrt(s->rms(k) / std::max(1, s->samples));
  s->channel_score = Vec6<double>::Zero();
  s->channel_score(k) = s->score;
}

// Slices by channel, force magnitude (share of the log's peak) and loading
// direction (the magnitude rising, falling, or held within 5 % of its
// fastest rate).
void SliceTheGap(const std::vector<Experiment>& logs,
                 const std::vector<std::vector<Vec6<double>>>& residuals,
                 DiagnosisResult* result) {
  const char* magnitude_names[] = {"near_zero", "low", "mid", "high"};
  const char* direction_names[] = {"loading", "unloading", "hold"};
  std::vector<GapSlice> magnitude(4), direction(3), channels(6);
  for (int i = 0; i < 4; ++i) magnitude[i].name = magnitude_names[i];
  for (int i = 0; i < 3; ++i) direction[i].name = direction_names[i];
  for (int k = 0; k < 6; ++k) channels[k].name = kChannelNames[k];
  double total_excess = 0;
  for (size_t l = 0; l < logs.size(); ++l) {
    const Experiment& e = logs[l];
    const std::vector<Vec6<double>>& w = residuals[l];
    const ForceHistory h = HistoryOf(e, w.size());
    for (size_t j = 0; j < w.size(); ++j) {
      if (!Observed(e, j)) continue;
      const Vec6<double> r = w[j].cwiseProduct(e.sigma);
      const double level = h.magnitude[j] / h.peak_magnitude;
      const int m = level < 0.1 ? 0 : level < 0.4 ? 1 : level < 0.7 ? 2 : 3;
      const int d = std::abs(h.rate[j]) <= 0.05 * h.fastest_rate ? 2
                    : h.rate[j] > 0                              ? 0
                                                                 : 1;
      AddToSlice(w[j], r, &magnitude[m]);
      AddToSlice(w[j], r, &direction[d]);
      for (int k = 0; k < 6; ++k) {
        channels[k].samples += 1;
        channels[k].channel_score(k) += w[j](k) * w[j](k);
        channels[k].mean(k) += r(k);
        channels[k].rms(k) += r(k) * r(k);
      }
      total_excess += w[j].squaredNorm() - 6;
    }
  }
  for (GapSlice& s : magnitude) FinishSlice(total_excess, &s);
  for (GapSlice& s : direction) FinishSlice(total_excess, &s);
  for (int k = 0; k < 6; ++k) FinishChannelSlice(total_excess, k, &channels[k]);
  result->channels = channels;
  result->magnitude = magnitude;
  result->direction = direction;
}

// The residuals' energy share per frequency band (edges 0, 0.5, 2, 10,
// 50 Hz and Nyquist), over every channel and log.
void ResidualSpectrum(const std::vector<Experiment>& logs,
                      const std::vector<std::vector<Vec6<double>>>& residuals,
                      DiagnosisResult* result) {
  const std::vector<double> band_edges = {0, 0.5, 2, 10, 50};
  const double nyquist = 0.5 / logs.front().sample_period;
  result->bands.clear();
  for (size_t b = 0; b < band_edges.size(); ++b) {
    const double high = b + 1 < band_edges.size() ? band_edges[b + 1] : nyquist;
    if (band_edges[b] >= nyquist) break;
    result->bands.push_back(
        {band_edges[b], std::min(high, nyquist), 0,
         (std::min(high, nyquist) - band_edges[b]) / nyquist});
  }
  std::vector<double> band_energy(band_edges.size(), 0.0);
  double total_energy = 0;
  for (size_t l = 0; l < logs.size(); ++l) {
    const std::vector<Vec6<double>>& w = residuals[l];
    const size_t n = w.size();
    // Zero-padded to a power of two: a log's length may be prime, which
    // costs a mixed-radix FFT O(n^2); the band shares do not change.
    Eigen::FFT<double> fft;
    size_t padded = 1;
    while (padded < n) padded *= 2;
    std::vector<double> series(padded, 0.0);
    std::vector<std::complex<double>> spectrum;
    for (int k = 0; k < 6; ++k) {
      double mean = 0;
      for (size_t j = 0; j < n; ++j) mean += w[j](k) / n;
      for (size_t j = 0; j < n; ++j) series[j] = w[j](k) - mean;
      fft.fwd(spectrum, series);
      for (size_t i = 1; i <= padded / 2; ++i) {
        const double f = i / (padded * logs[l].sample_period);
        const double energy = std::norm(spectrum[i]);
        total_energy += energy;
        for (size_t b = result->bands.size(); b-- > 0;) {
          if (f >= result->bands[b].low_hz) {
            band_energy[b] += energy;
            break;
          }
        }
      }
    }
  }
  for (size_t b = 0; b < result->bands.size(); ++b) {
    result->bands[b].energy_share =
        total_energy > 0 ? band_energy[b] / total_energy : 0;
  }
}

// Per channel, the strongest correlation of the residual with the force
// along its direction and with the force's rate, within +-max_lag, averaged
// over the logs weighted by their length.
void LagCorrelations(const std::vector<Experiment>& logs,
                     const std::vector<std::vector<Vec6<double>>>& residuals,
                     double max_lag, DiagnosisResult* result) {
  std::vector<std::vector<double>> force_corr(6), rate_corr(6);
  double weight = 0;
  int max_lag_samples = 0;
  for (size_t l = 0; l < logs.size(); ++l) {
    const Experiment& e = logs[l];
    const std::vector<Vec6<double>>& w = residuals[l];
    const size_t n = w.size();
    const ForceHistory h = HistoryOf(e, n);
    const int lags = static_cast<int>(std::lround(max_lag / e.sample_period));
    if (max_lag_samples == 0) {
      max_lag_samples = lags;
      for (int k = 0; k < 6; ++k) {
        force_corr[k].assign(2 * lags + 1, 0.0);
        rate_corr[k].assign(2 * lags + 1, 0.0);
      }
    }
    const int used = std::min(lags, max_lag_samples);
    std::vector<double> channel(n);
    for (int k = 0; k < 6; ++k) {
      for (size_t j = 0; j < n; ++j) channel[j] = w[j](k);
      for (int lag = -used; lag <= used; ++lag) {
        force_corr[k][lag + max_lag_samples] +=
            LaggedCorrelation(channel, h.along, lag) * n;
        rate_corr[k][lag + max_lag_samples] +=
            LaggedCorrelation(channel, h.rate, lag) * n;
      }
    }
    weight += static_cast<double>(n);
  }
  const double period = logs.front().sample_period;
  result->lags.clear();
  for (int k = 0; k < 6; ++k) {
    LagCorrelation c;
    c.channel = kChannelNames[k];
    for (int i = 0; i < 2 * max_lag_samples + 1; ++i) {
      const double fc = force_corr[k][i] / weight;
      const double rc = rate_corr[k][i] / weight;
      if (std::abs(fc) > std::abs(c.force_correlation)) {
        c.force_correlation = fc;
        c.force_lag = (i - max_lag_samples) * period;
      }
      if (std::abs(rc) > std::abs(c.rate_correlation)) {
        c.rate_correlation = rc;
        c.rate_lag = (i - max_lag_samples) * period;
      }
    }
    result->lags.push_back(c);
  }
}

}  // namespace

void Localize(const std::vector<Experiment>& logs,
              const std::vector<std::vector<Vec6<double>>>& residuals,
              const DiagnosisOptions& options, DiagnosisResult* result) {
  SliceTheGap(logs, residuals, result);
  ResidualSpectrum(logs, residuals, result);
  LagCorrelations(logs, residuals, options.max_lag, result);
}

}  // namespace kcrig
