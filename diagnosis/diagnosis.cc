#include "diagnosis/diagnosis.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <mutex>
#include <numeric>

#include "base/parallel_for.h"
#include "unsupported/Eigen/FFT"

namespace kcrig {
namespace {

// Weighted residuals (sensed - measured) / sigma per sample (zero where
// not observed) of a model at `values`.
Status WeightedResiduals(const EffectModel& model,
                         const std::vector<double>& values, const Experiment& e,
                         double step, std::vector<Vec6<double>>* weighted) {
  std::vector<Vec6<double>> sensed;
  const Status status = SimulateEffectModel(model, values, e, step, &sensed);
  if (!status.ok()) return status;
  weighted->resize(sensed.size());
  for (size_t j = 0; j < sensed.size(); ++j) {
    (*weighted)[j] =
        Observed(e, j)
            ? Vec6<double>((sensed[j] - e.measured[j]).cwiseQuotient(e.sigma))
            : Vec6<double>::Zero();
  }
  return Status::Ok();
}

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
double LjungBox(const std::vector<double>& x, int lags) {
  const size_t n = x.size();
  const double mean = std::accumulate(x.begin(), x.end(), 0.0) / n;
  double variance = 0;
  for (double v : x) variance += (v - mean) * (v - mean);
  if (!(variance > 0)) return 0;
  double q = 0;
  for (int k = 1; k <= lags; ++k) {
    double c = 0;
    for (size_t j = k; j < n; ++j) c += (x[j] - mean) * (x[j - k] - mean);
    const double rho = c / variance;
    q += rho * rho / static_cast<double>(n - k);
  }
  return static_cast<double>(n) * (n + 2.0) * q;
}

// Whether residuals are white: the smallest Ljung-Box p-value over the
// channels of all logs, Bonferroni-corrected for their number.
double WhitenessP(const std::vector<Experiment>& logs,
                  const std::vector<std::vector<Vec6<double>>>& residuals,
                  int lags) {
  double min_p = 1;
  for (size_t l = 0; l < logs.size(); ++l) {
    for (int k = 0; k < 6; ++k) {
      std::vector<double> x;
      for (size_t j = 0; j < residuals[l].size(); ++j) {
        if (Observed(logs[l], j)) x.push_back(residuals[l][j](k));
      }
      min_p = std::min(min_p, ChiSquareUpperTail(LjungBox(x, lags), lags));
    }
  }
  return std::min(1.0, min_p * 6 * static_cast<double>(logs.size()));
}

// Pearson correlation of a[j] with b[j - lag] over the overlap.
double LaggedCorrelation(const std::vector<double>& a,
                         const std::vector<double>& b, int lag) {
  const int n = static_cast<int>(a.size());
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  int count = 0;
  for (int j = std::max(0, lag); j < std::min(n, n + lag); ++j) {
    const double x = a[j], y = b[j - lag];
    sa += x;
    sb += y;
    saa += x * x;
    sbb += y * y;
    sab += x * y;
    ++count;
  }
  if (count < 3) return 0;
  const double cov = sab - sa * sb / count;
  const double va = saa - sa * sa / count, vb = sbb - sb * sb / count;
  return va > 0 && vb > 0 ? cov / std::sqrt(va * vb) : 0;
}

void Localize(const std::vector<Experiment>& logs,
              const std::vector<std::vector<Vec6<double>>>& residuals,
              const DiagnosisOptions& options, DiagnosisResult* result) {
  // Slices by channel, force magnitude and loading direction.
  const char* magnitude_names[] = {"near_zero", "low", "mid", "high"};
  const char* direction_names[] = {"loading", "unloading", "hold"};
  std::vector<GapSlice> magnitude(4), direction(3), channels(6);
  for (int i = 0; i < 4; ++i) magnitude[i].name = magnitude_names[i];
  for (int i = 0; i < 3; ++i) direction[i].name = direction_names[i];
  for (int k = 0; k < 6; ++k) channels[k].name = kChannelNames[k];
  double total_excess = 0;
  GapSlice all;
  auto add = [](GapSlice* s, const Vec6<double>& w, const Vec6<double>& r) {
    s->samples += 1;
    s->channel_score += w.cwiseAbs2();
    s->mean += r;
    s->rms += r.cwiseAbs2();
  };
  const std::vector<double> band_edges = {0, 0.5, 2, 10, 50};
  std::vector<double> band_energy;
  double total_energy = 0;
  std::vector<std::vector<double>> force_corr(6), rate_corr(6);
  std::vector<double> lag_weight;
  int max_lag_samples = 0;

  for (size_t l = 0; l < logs.size(); ++l) {
    const Experiment& e = logs[l];
    const std::vector<Vec6<double>>& w = residuals[l];
    const size_t n = w.size();
    // Force along the excitation's main direction, its magnitude and rate.
    Eigen::Vector2d direction_xy = Eigen::Vector2d::Zero();
    double peak = 0;
    for (const Vec3<double>& f : e.forces) {
      if (f.head<2>().norm() > peak) {
        peak = f.head<2>().norm();
        direction_xy = f.head<2>() / peak;
      }
    }
    std::vector<double> along(n), magnitude_of(n), rate(n);
    for (size_t j = 0; j < n; ++j) {
      along[j] = e.forces[j].head<2>().dot(direction_xy);
      magnitude_of[j] = e.forces[j].norm();
    }
    const size_t half = std::max<size_t>(
        1, static_cast<size_t>(std::lround(0.01 / e.sample_period)));
    for (size_t j = 0; j < n; ++j) {
      const size_t a = j >= half ? j - half : 0, b = std::min(n - 1, j + half);
      rate[j] = b > a ? (magnitude_of[b] - magnitude_of[a]) /
                            ((b - a) * e.sample_period)
                      : 0;
    }
    const double fmax = std::max(
        1.0, *std::max_element(magnitude_of.begin(), magnitude_of.end()));
    double fastest = 0;
    for (double r : rate) fastest = std::max(fastest, std::abs(r));
    for (size_t j = 0; j < n; ++j) {
      if (!Observed(e, j)) continue;
      const Vec6<double> r = w[j].cwiseProduct(e.sigma);
      const double level = magnitude_of[j] / fmax;
      const int m = level < 0.1 ? 0 : level < 0.4 ? 1 : level < 0.7 ? 2 : 3;
      const int d = std::abs(rate[j]) <= 0.05 * fastest ? 2
                    : rate[j] > 0                       ? 0
                                                        : 1;
      add(&magnitude[m], w[j], r);
      add(&direction[d], w[j], r);
      add(&all, w[j], r);
      for (int k = 0; k < 6; ++k) {
        channels[k].samples += 1;
        channels[k].channel_score(k) += w[j](k) * w[j](k);
        channels[k].mean(k) += r(k);
        channels[k].rms(k) += r(k) * r(k);
      }
      total_excess += w[j].squaredNorm() - 6;
    }

    // Residual spectrum per channel.
    const double nyquist = 0.5 / e.sample_period;
    if (band_energy.empty()) {
      band_energy.assign(band_edges.size(), 0.0);
      result->bands.clear();
      for (size_t b = 0; b < band_edges.size(); ++b) {
        const double high =
            b + 1 < band_edges.size() ? band_edges[b + 1] : nyquist;
        if (band_edges[b] >= nyquist) break;
        result->bands.push_back(
            {band_edges[b], std::min(high, nyquist), 0,
             (std::min(high, nyquist) - band_edges[b]) / nyquist});
      }
    }
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
        const double f = i / (padded * e.sample_period);
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

    // Cross-correlation with the force and its rate.
    const int lags =
        static_cast<int>(std::lround(options.max_lag / e.sample_period));
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
            LaggedCorrelation(channel, along, lag) * n;
        rate_corr[k][lag + max_lag_samples] +=
            LaggedCorrelation(channel, rate, lag) * n;
      }
    }
    lag_weight.push_back(static_cast<double>(n));
  }

  auto finish = [&](GapSlice* s) {
    if (s->samples == 0) return;
    s->excess_share =
        total_excess != 0
            ? (s->channel_score.sum() - 6.0 * s->samples) / total_excess
            : 0;
    s->channel_score /= s->samples;
    s->mean /= s->samples;
    s->rms = (s->rms / s->samples).cwiseSqrt();
    s->score = s->channel_score.mean();
  };
  for (GapSlice& s : magnitude) finish(&s);
  for (GapSlice& s : direction) finish(&s);
  for (int k = 0; k < 6; ++k) {
    GapSlice& s = channels[k];
    s.excess_share =
        total_excess != 0 ? (s.channel_score(k) - s.samples) / total_excess : 0;
    s.score = s.samples > 0 ? s.channel_score(k) / s.samples : 0;
    s.mean(k) /= std::max(1, s.samples);
    s.rms(k) = std::sqrt(s.rms(k) / std::max(1, s.samples));
    s.channel_score = Vec6<double>::Zero();
    s.channel_score(k) = s.score;
  }
  result->channels = channels;
  result->magnitude = magnitude;
  result->direction = direction;
  for (size_t b = 0; b < result->bands.size(); ++b) {
    result->bands[b].energy_share =
        total_energy > 0 ? band_energy[b] / total_energy : 0;
  }
  const double weight =
      std::accumulate(lag_weight.begin(), lag_weight.end(), 0.0);
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

// The information criteria of a fit with chi-square `chi2`, k parameters
// and m residuals.
void InformationCriteria(double chi2, int k, int m, CandidateScore* s) {
  s->train_chi2 = chi2;
  s->num_parameters = k;
  s->bic = chi2 + k * std::log(static_cast<double>(m));
  s->aicc =
      chi2 + 2.0 * k + (m > k + 1 ? 2.0 * k * (k + 1) / (m - k - 1) : 0.0);
}

// log Gamma-regularized upper incomplete gamma Q(a, x): series below a + 1,
// continued fraction (modified Lentz) above.
double UpperIncompleteGamma(double a, double x) {
  if (x <= 0) return 1.0;
  const double log_prefix = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 100000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-15) break;
    }
    return std::max(0.0, 1.0 - sum * std::exp(log_prefix));
  }
  const double tiny = 1e-300;
  double b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1) < 1e-15) break;
  }
  return std::exp(log_prefix) * h;
}

}  // namespace

double ChiSquareUpperTail(double x, double dof) {
  if (!(dof > 0)) return 1.0;  // no degrees of freedom: no evidence
  if (!(x < std::numeric_limits<double>::infinity())) return 0.0;  // inf, NaN
  return UpperIncompleteGamma(0.5 * dof, 0.5 * x);
}

Status Diagnose(const SuspensionParameters<double>& nominal,
                const std::vector<Experiment>& training,
                const std::vector<Experiment>& holdout,
                const DiagnosisOptions& options, double step,
                DiagnosisResult* result) {
  const auto start = std::chrono::steady_clock::now();
  *result = DiagnosisResult();
  if (training.empty()) return Status::Error("diagnose: no training log");
  if (options.candidates.empty()) {
    return Status::Error("diagnose: no candidate effect");
  }
  for (size_t i = 0; i < options.candidates.size(); ++i) {
    for (size_t k = 0; k < i; ++k) {
      if (options.candidates[k] == options.candidates[i]) {
        return Status::Error("diagnose: candidate '" + options.candidates[i] +
                             "' given twice");
      }
    }
  }
  if (options.ljung_box_lags < 1 ||
      options.min_samples < options.ljung_box_lags + 20 ||
      options.retry_pool < 0 || options.num_threads < 1) {
    return Status::Error(
        "diagnose: options need ljung_box_lags >= 1, min_samples >= "
        "ljung_box_lags + 20, retry_pool >= 0 and num_threads >= 1");
  }
  for (const std::vector<Experiment>* set : {&training, &holdout}) {
    for (const Experiment& e : *set) {
      const int n = ObservedCount(e);
      if (n < options.min_samples) {
        return Status::Error(
            e.source + ": " + std::to_string(n) +
            " observed samples; a diagnosis needs at least " +
            std::to_string(options.min_samples) +
            " per log for its residual statistics (record a longer ramp)");
      }
    }
  }
  const double lower = options.estimator.lower_scale;
  const double upper = options.estimator.upper_scale;
  EffectModel nominal_model;
  Status status =
      EffectModel::Create(nominal, {}, lower, upper, &nominal_model);
  if (!status.ok()) return status;
  std::vector<EffectModel> singles;
  for (const std::string& name : options.candidates) {
    EffectModel m;
    status = EffectModel::Create(nominal, {name}, lower, upper, &m);
    if (!status.ok()) return Status::Error("diagnose: " + status.message());
    singles.push_back(std::move(m));
  }
  EffectFitOptions fit_options = options.fit;
  fit_options.uncertainty = options.estimator;
  std::mutex progress_mutex;
  // The fraction done is a rough guide from typical stage costs: the fits
  // of the single effects take about half of a diagnosis, pairs a quarter.
  auto progress = [&](const std::string& text, double fraction) {
    if (!options.on_progress) return;
    std::lock_guard<std::mutex> lock(progress_mutex);
    options.on_progress(text, fraction);
  };
  progress("nominal fit", 0);

  // 1. The nominal fit and its gap tests.
  CandidateScore& nominal_score = result->nominal;
  nominal_score.model = "nominal";
  status = FitEffectModel(nominal_model, training, {}, fit_options, step,
                          &nominal_score.fit);
  if (!status.ok()) return status;
  std::vector<std::vector<Vec6<double>>> residuals(training.size());
  int m = 0;
  double chi2 = 0;
  for (size_t l = 0; l < training.size(); ++l) {
    status = WeightedResiduals(nominal_model, nominal_score.fit.values,
                               training[l], step, &residuals[l]);
    if (!status.ok()) return status;
    for (size_t j = 0; j < residuals[l].size(); ++j) {
      if (!Observed(training[l], j)) continue;
      chi2 += residuals[l][j].squaredNorm();
      m += 6;
    }
  }
  const int n_nominal = nominal_model.num_parameters();
  result->chi2 = chi2;
  result->dof = m - n_nominal;
  result->chi2_p = ChiSquareUpperTail(chi2, result->dof);
  result->ljung_box_p = WhitenessP(training, residuals, options.ljung_box_lags);
  result->gap = result->chi2_p < options.significance ||
                result->ljung_box_p < options.significance;
  InformationCriteria(chi2, n_nominal, m, &nominal_score);

  // 2. Where the gap lies.
  progress("localisation and per-log fits", 0.1);
  Localize(training, residuals, options, result);

  // Scores models (their `fit` set) on data they were not fitted to: the
  // hold-out logs, or each training log predicted by the fit to the others
  // (one Gauss-Newton step from the full fit on the other logs: the
  // one-step approximation of the fold's refit; all folds of all models
  // side by side), or, with one log only, the training chi-square per
  // degree of freedom.
  auto score_models = [&](const std::vector<const EffectModel*>& models,
                          const std::vector<CandidateScore*>& scores) {
    const int count = static_cast<int>(models.size());
    const int folds = holdout.empty() && training.size() > 1
                          ? static_cast<int>(training.size())
                          : 0;
    std::vector<ScoreSum> sums(count);
    std::vector<std::vector<Vec6<double>>> fold_residuals(count * folds);
    std::vector<Status> fold_status(count * folds);
    ParallelFor(count * folds, options.num_threads, [&](int job) {
      const int i = job / folds, l = job % folds;
      const EffectModel& model = *models[i];
      std::vector<Experiment> rest;
      for (int o = 0; o < folds; ++o) {
        if (o != l) rest.push_back(training[o]);
      }
      std::vector<double> fold;
      fold_status[job] =
          RefitOneStep(model, scores[i]->fit.values, rest, step, &fold);
      if (!fold_status[job].ok()) return;
      fold_status[job] = WeightedResiduals(model, fold, training[l], step,
                                           &fold_residuals[job]);
    });
    for (int i = 0; i < count; ++i) {
      CandidateScore* s = scores[i];
      const EffectModel& model = *models[i];
      s->model = model.Name();
      InformationCriteria(2 * s->fit.result.cost, model.num_parameters(), m, s);
      Status st = Status::Ok();
      // Whiteness is tested where the chi-square of `at_noise` is: on the
      // hold-out logs, else on the full fit's training residual.
      const std::vector<Experiment>& tested =
          holdout.empty() ? training : holdout;
      std::vector<std::vector<Vec6<double>>> w(tested.size());
      for (size_t l = 0; l < tested.size() && st.ok(); ++l) {
        st = WeightedResiduals(model, s->fit.values, tested[l], step, &w[l]);
        if (st.ok() && !holdout.empty()) sums[i].Add(tested[l], w[l]);
      }
      if (st.ok()) {
        s->ljung_box_p = WhitenessP(tested, w, options.ljung_box_lags);
      }
      if (holdout.empty()) {
        for (int l = 0; l < folds && st.ok(); ++l) {
          st = fold_status[i * folds + l];
          if (st.ok()) sums[i].Add(training[l], fold_residuals[i * folds + l]);
        }
      }
      s->ok = st.ok();
      s->error = st.message();
      if (!s->ok) continue;
      s->scored = true;
      if (!holdout.empty() || folds > 0) {
        s->heldout = true;
        s->score = sums[i].Score();
        s->heldout_rms = sums[i].Rms();
      } else {
        s->score = s->train_chi2 / std::max(1, m - model.num_parameters());
      }
    }
  };
  // Per-log nominal fits: the stiffness drift between experiments.
  std::vector<EffectFit> per_log(training.size() > 1 ? training.size() : 0);
  std::vector<Status> per_log_status(per_log.size());
  ParallelFor(
      static_cast<int>(per_log.size()), options.num_threads, [&](int l) {
        per_log_status[l] = FitEffectModel(nominal_model, {training[l]},
                                           nominal_score.fit.values,
                                           fit_options, step, &per_log[l]);
      });
  // A log whose own fit fails leaves the drift table empty (it is
  // evidence, not a precondition of the diagnosis).
  const bool drift_available =
      std::all_of(per_log_status.begin(), per_log_status.end(),
                  [](const Status& s) { return s.ok(); });
  for (int i = 0; i < kNumBushings && per_log.size() > 1 && drift_available;
       ++i) {
    StiffnessDrift d;
    d.parameter = nominal_model.parameters()[i].name;
    for (const EffectFit& f : per_log) {
      d.values.push_back(f.result.parameters[i].value);
      d.standard_errors.push_back(f.result.parameters[i].standard_error);
    }
    for (size_t a = 0; a < per_log.size(); ++a) {
      for (size_t b = a + 1; b < per_log.size(); ++b) {
        const double se =
            std::hypot(d.standard_errors[a], d.standard_errors[b]);
        if (std::isfinite(se) && se > 0) {
          d.max_z = std::max(d.max_z, std::abs(d.values[a] - d.values[b]) / se);
        }
      }
    }
    d.drifts = d.max_z > options.drift_z;
    result->drift_detected = result->drift_detected || d.drifts;
    result->drift.push_back(d);
  }

  result->scoring = !holdout.empty()      ? "holdout"
                    : training.size() > 1 ? "cross_validation"
                                          : "information_criterion";
  auto finish_time = [&] {
    result->seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count();
  };
  if (!result->gap) {
    result->verdict = "none";
    result->reason =
        "the nominal model's residual is consistent with the sensor noise "
        "(chi-square and Ljung-Box tests)";
    finish_time();
    return Status::Ok();
  }

  // 3. Candidates: fitted, then scored like the nominal model.
  score_models({&nominal_model}, {&nominal_score});
  if (!nominal_score.ok) return Status::Error(nominal_score.error);
  const double nominal_gap = nominal_score.score - 1.0;
  const long n_scored = holdout.empty() ? m : [&] {
    long n = 0;
    for (const Experiment& e : holdout) n += 6L * ObservedCount(e);
    return n;
  }();
  // Five standard deviations of a score at the noise floor.
  const double score_noise = 5 * std::sqrt(2.0 / n_scored);
  if (result->scoring != "information_criterion" && nominal_gap < score_noise) {
    // The training tests found structure that the data the candidates
    // would be scored on do not show: nothing to attribute there.
    char text[200];
    std::snprintf(text, sizeof(text),
                  "the training logs' gap is not reproduced by the %s "
                  "(nominal score %.4g, noise floor 1): nothing to attribute",
                  holdout.empty() ? "cross-validation" : "hold-out logs",
                  nominal_score.score);
    result->verdict = "unexplained";
    result->reason = text;
    finish_time();
    return Status::Ok();
  }
  // Fits each model from its starts, one after the other: while no model
  // has brought the training residual down to the noise, a further start
  // is tried for the `retry_pool` models that fit the training logs best
  // so far (the fits of all models side by side). Then scores the best fit
  // of each.
  using Start = std::vector<double>;
  auto fit_and_score = [&](const std::vector<const EffectModel*>& models,
                           const std::vector<std::vector<Start>>& starts,
                           double from, double to,
                           std::vector<CandidateScore>* scores) {
    const int count = static_cast<int>(models.size());
    scores->assign(count, CandidateScore());
    std::vector<bool> fitted(count, false);
    std::vector<Status> fit_status(count, Status::Ok());
    size_t round_count = 0;
    for (const std::vector<Start>& s : starts) {
      round_count = std::max(round_count, s.size());
    }
    std::atomic<int> done{0};
    auto fits_to_noise = [&](int i) {
      const EffectFit& best = (*scores)[i].fit;
      const int dof = best.result.num_residuals - models[i]->num_parameters();
      return fitted[i] && ChiSquareUpperTail(2 * best.result.cost, dof) >=
                              options.significance;
    };
    for (size_t round = 0; round < round_count; ++round) {
      std::vector<int> todo;
      bool any_at_noise = false;
      for (int i = 0; i < count; ++i) any_at_noise |= fits_to_noise(i);
      if (any_at_noise) break;
      for (int i = 0; i < count; ++i) {
        if (round < starts[i].size()) todo.push_back(i);
      }
      if (round > 0) {
        // Unfitted models first, then by training cost.
        std::stable_sort(todo.begin(), todo.end(), [&](int a, int b) {
          if (fitted[a] != fitted[b]) return !fitted[a];
          return (*scores)[a].fit.result.cost < (*scores)[b].fit.result.cost;
        });
        if (static_cast<int>(todo.size()) > options.retry_pool) {
          todo.resize(options.retry_pool);
        }
      }
      std::vector<EffectFit> fits(todo.size());
      std::vector<Status> status_of(todo.size());
      ParallelFor(
          static_cast<int>(todo.size()), options.num_threads, [&](int k) {
            const int i = todo[k];
            status_of[k] =
                FitEffectModel(*models[i], training, starts[i][round],
                               fit_options, step, &fits[k]);
            const int finished = ++done;
            progress("candidate fits " + std::to_string(finished) + " (" +
                         models[i]->Name() + ")",
                     from + (to - from) * 0.9 *
                                std::min(1.0, static_cast<double>(finished) /
                                                  count));
          });
      for (size_t k = 0; k < todo.size(); ++k) {
        const int i = todo[k];
        if (!status_of[k].ok()) {
          if (!fitted[i]) fit_status[i] = status_of[k];
          continue;
        }
        if (!fitted[i] || fits[k].result.cost < (*scores)[i].fit.result.cost) {
          (*scores)[i].fit = fits[k];
        }
        fitted[i] = true;
      }
    }
    progress("scoring " + std::to_string(count) + " candidates (" +
                 result->scoring + ")",
             from + (to - from) * 0.9);
    std::vector<const EffectModel*> ok_models;
    std::vector<CandidateScore*> ok_scores;
    for (int i = 0; i < count; ++i) {
      CandidateScore& s = (*scores)[i];
      s.model = models[i]->Name();
      if (!fitted[i]) {
        s.ok = false;
        s.error = fit_status[i].message();
        continue;
      }
      ok_models.push_back(models[i]);
      ok_scores.push_back(&s);
    }
    score_models(ok_models, ok_scores);
    for (CandidateScore* s : ok_scores) {
      s->gap_closed = s->ok && nominal_gap > 0
                          ? (nominal_score.score - s->score) / nominal_gap
                          : 0;
    }
  };
  std::vector<const EffectModel*> single_models;
  // A single effect is fitted from two starts: the nominal fit's
  // stiffnesses (which the effect has biased) with a small effect, and the
  // configured stiffnesses with a large one.
  std::vector<std::vector<Start>> single_starts;
  for (const EffectModel& m1 : singles) {
    single_models.push_back(&m1);
    Start biased, configured;
    for (int p = 0; p < m1.num_parameters(); ++p) {
      const EffectParameter& ep = m1.parameters()[p];
      biased.push_back(p < kNumBushings ? nominal_score.fit.values[p]
                                        : ep.initial);
      configured.push_back(ep.second_initial);
    }
    single_starts.push_back({biased, configured});
  }
  fit_and_score(single_models, single_starts, 0.15, 0.75, &result->ranking);
  auto rank = [](std::vector<CandidateScore>* list) {
    std::stable_sort(list->begin(), list->end(),
                     [](const CandidateScore& a, const CandidateScore& b) {
                       if (a.ok != b.ok) return a.ok;
                       if (a.score != b.score) return a.score < b.score;
                       return a.bic < b.bic;
                     });
  };
  rank(&result->ranking);

  // 4. The verdict.
  // `best` is clearly better than `other`: it closes min_gap_margin more
  // of the gap, or leaves a third of the other's remaining gap (not less
  // than five standard deviations of a score at the noise floor), and the
  // BIC prefers it strongly.
  auto clearly_better = [&](const CandidateScore& best,
                            const CandidateScore& other) {
    if (!other.ok) return true;
    const bool closes_more =
        best.gap_closed - other.gap_closed >= options.min_gap_margin ||
        other.score - 1 >= 3 * std::max(best.score - 1, score_noise);
    return closes_more && other.bic - best.bic >= options.min_bic_difference;
  };
  // Whether list[0] closes enough of the gap and is clearly the best.
  auto decide = [&](const std::vector<CandidateScore>& list) {
    if (list.empty() || !list[0].ok) return false;
    if (list[0].gap_closed < options.min_gap_closed) return false;
    return list.size() < 2 || clearly_better(list[0], list[1]);
  };
  // Whether a model leaves nothing but noise on the data it was scored on.
  // On hold-out logs that is their chi-square; a cross-validation fold
  // fitted to fewer logs extrapolates with a larger parameter uncertainty,
  // so there (and with one log) the full fit's training chi-square is
  // tested instead.
  // Nothing but noise also means white: a model that mimics an effect it
  // does not contain (a geometry error fitted as a sensor scale) can bring
  // the chi-square down to the noise and still leave a correlated residual.
  auto at_noise = [&](const CandidateScore& s) {
    const double p =
        holdout.empty() ? ChiSquareUpperTail(s.train_chi2, m - s.num_parameters)
                        : ChiSquareUpperTail(s.score * n_scored,
                                             static_cast<double>(n_scored));
    return p >= options.significance && s.ljung_box_p >= options.significance;
  };
  std::vector<CandidateScore> pairs;
  const CandidateScore* chosen = nullptr;
  if (decide(result->ranking)) chosen = &result->ranking[0];
  if (options.consider_pairs && result->ranking.size() > 1 &&
      (chosen == nullptr
           ? result->ranking[0].gap_closed < options.min_gap_closed
           : !at_noise(*chosen))) {
    // No single effect suffices, or the best leaves structure: pairs of
    // the best few.
    std::vector<EffectModel> pair_models;
    const int pool = std::min<int>(options.pair_pool, result->ranking.size());
    for (int a = 0; a < pool; ++a) {
      for (int b = a + 1; b < pool; ++b) {
        EffectModel pm;
        const std::vector<std::string> both = {result->ranking[a].model,
                                               result->ranking[b].model};
        if (EffectModel::Create(nominal, both, lower, upper, &pm).ok() &&
            pm.num_parameters() <= kMaxEffectModelParameters) {
          pair_models.push_back(std::move(pm));
        }
      }
    }
    // A pair starts from its two single fits: the stiffnesses of the
    // better one, each effect's parameters from its own fit.
    std::vector<const EffectModel*> pointers;
    std::vector<std::vector<Start>> pair_starts;
    for (const EffectModel& pm : pair_models) {
      pointers.push_back(&pm);
      Start start;
      for (int p = 0; p < pm.num_parameters(); ++p) {
        const EffectParameter& ep = pm.parameters()[p];
        const std::string& owner =
            p < kNumBushings ? pm.effects()[0] : ep.effect;
        for (const CandidateScore& single : result->ranking) {
          if (single.model != owner || !single.ok) continue;
          for (size_t q = 0; q < single.fit.result.parameters.size(); ++q) {
            const std::string& name = single.fit.result.parameters[q].name;
            if (name ==
                (p < kNumBushings ? ep.name : ep.effect + "." + ep.name)) {
              start.push_back(single.fit.values[q]);
            }
          }
        }
        if (static_cast<int>(start.size()) != p + 1) {
          start.push_back(p < kNumBushings ? nominal_score.fit.values[p]
                                           : ep.initial);
        }
      }
      pair_starts.push_back({start});
    }
    fit_and_score(pointers, pair_starts, 0.75, 0.97, &pairs);
    rank(&pairs);
    // A pair must beat the best single effect clearly too.
    const bool pair_wins =
        decide(pairs) && clearly_better(pairs[0], result->ranking[0]);
    const std::string chosen_name = pair_wins           ? pairs[0].model
                                    : chosen != nullptr ? chosen->model
                                                        : "";
    result->ranking.insert(result->ranking.end(), pairs.begin(), pairs.end());
    rank(&result->ranking);
    chosen = nullptr;
    for (const CandidateScore& s : result->ranking) {
      if (s.model == chosen_name) chosen = &s;
    }
  }

  char text[300];
  if (chosen != nullptr) {
    result->verdict = chosen->model;
    // High confidence: the model leaves nothing but noise on the data it
    // was scored on.
    result->confidence = at_noise(*chosen) ? "high" : "low";
    std::snprintf(text, sizeof(text),
                  "%s closes %.0f %% of the gap (score %.3g -> %.3g, noise "
                  "floor 1)%s",
                  chosen->model.c_str(), 100 * chosen->gap_closed,
                  nominal_score.score, chosen->score,
                  result->confidence == "high"
                      ? "; what is left is noise"
                      : "; some structure is left beyond the noise");
    result->reason = text;
  } else {
    result->verdict = "unexplained";
    const CandidateScore& best = result->ranking.front();
    const CandidateScore* second =
        result->ranking.size() > 1 ? &result->ranking[1] : nullptr;
    if (best.gap_closed >= options.min_gap_closed && second != nullptr &&
        second->gap_closed >= options.min_gap_closed) {
      result->ambiguous_a = best.model;
      result->ambiguous_b = second->model;
      std::snprintf(text, sizeof(text),
                    "%s and %s both explain the data (%.0f %% and %.0f %% of "
                    "the gap closed): an experiment that tells them apart is "
                    "needed",
                    best.model.c_str(), second->model.c_str(),
                    100 * best.gap_closed, 100 * second->gap_closed);
    } else {
      std::snprintf(text, sizeof(text),
                    "no candidate closes %.0f %% of the gap (best: %s, "
                    "%.0f %%); see the localisation",
                    100 * options.min_gap_closed, best.model.c_str(),
                    100 * best.gap_closed);
    }
    result->reason = text;
  }
  finish_time();
  return Status::Ok();
}

}  // namespace kcrig
