#include "estimator/adequacy.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>

#include "Eigen/QR"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

// Regularized upper incomplete gamma Q(a, x): series below a + 1,
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

std::vector<double> ObservedSeries(const Experiment& log,
                                   const std::vector<Vec6<double>>& weighted,
                                   int channel) {
  std::vector<double> x;
  x.reserve(weighted.size());
  for (size_t j = 0; j < weighted.size(); ++j) {
    if (Observed(log, j)) x.push_back(weighted[j](channel));
  }
  return x;
}

// The one line that says why a model is inadequate: the chi-square when it
// fails, and the channels whose residual is not white.
std::string InadequacyReason(const Adequacy& a, double significance) {
  std::string reason;
  char text[160];
  if (a.p_value < significance) {
    std::snprintf(text, sizeof(text),
                  "residual beyond the sensor noise (chi-square/dof %.3f, p "
                  "%.2g)",
                  a.dof > 0 ? a.chi_square / a.dof : 0.0, a.p_value);
    reason = text;
  }
  if (a.whiteness_p < significance) {
    std::string channels;
    for (int k = 0; k < 6; ++k) {
      const ChannelAdequacy& c = a.channels[k];
      if (c.used && c.whiteness_p < significance) {
        channels +=
            std::string(channels.empty() ? "" : ", ") + kChannelNames[k];
      }
    }
    std::snprintf(text, sizeof(text),
                  "%sresidual not white in %s (Ljung-Box p %.2g)",
                  reason.empty() ? "" : "; ", channels.c_str(), a.whiteness_p);
    reason += text;
  }
  return reason;
}

// The p-value of the chi-square and the verdict with its reason.
void Decide(const AdequacyOptions& options, Adequacy* a) {
  a->p_value = ChiSquareUpperTail(a->chi_square, a->dof);
  a->adequate = a->p_value >= options.significance &&
                a->whiteness_p >= options.significance;
  a->reason = a->adequate ? "" : InadequacyReason(*a, options.significance);
}

}  // namespace

std::vector<std::vector<Vec6<double>>> SplitResiduals(
    const std::vector<Experiment>& experiments,
    const std::vector<int>& channels, const Eigen::VectorXd& residuals) {
  std::vector<std::vector<Vec6<double>>> weighted(experiments.size());
  Eigen::Index row = 0;
  for (size_t l = 0; l < experiments.size(); ++l) {
    weighted[l].assign(experiments[l].measured.size(), Vec6<double>::Zero());
    for (Vec6<double>& sample : weighted[l]) {
      for (int k : channels) sample(k) = residuals(row++);
    }
  }
  return weighted;
}

Vec6<double> ResidualRms(
    const std::vector<Experiment>& experiments,
    const std::vector<std::vector<Vec6<double>>>& weighted) {
  Vec6<double> sum_squares = Vec6<double>::Zero();
  double count = 0;
  for (size_t l = 0; l < experiments.size(); ++l) {
    for (size_t j = 0; j < weighted[l].size(); ++j) {
      if (!Observed(experiments[l], j)) continue;
      sum_squares +=
          weighted[l][j].cwiseProduct(experiments[l].sigma).cwiseAbs2();
      count += 1;
    }
  }
  return count > 0 ? Vec6<double>((sum_squares / count).cwiseSqrt())
                   : Vec6<double>::Zero();
}

Adequacy AssessPredictionResiduals(const std::vector<Experiment>& logs,
                                   const std::vector<int>& channels,
                                   const Eigen::VectorXd& residuals,
                                   const Eigen::MatrixXd& jacobian,
                                   const Eigen::MatrixXd& information,
                                   const AdequacyOptions& options) {
  // (I_r + J C J^T)^-1 r = r - J (I + J^T J)^-1 J^T r (Woodbury, C = I^-1).
  const Eigen::MatrixXd posterior =
      information + jacobian.transpose() * jacobian;
  const Eigen::VectorXd shift =
      posterior.completeOrthogonalDecomposition().solve(jacobian.transpose() *
                                                        residuals);
  const Eigen::VectorXd decorrelated = residuals - jacobian * shift;
  return AssessPrediction(logs, SplitResiduals(logs, channels, residuals),
                          SplitResiduals(logs, channels, decorrelated),
                          channels, options);
}

void AddDiscretisationError(const std::vector<Experiment>& logs,
                            const std::vector<std::vector<Vec6<double>>>& error,
                            Adequacy* adequacy) {
  adequacy->discretisation = 0;
  for (int k = 0; k < 6; ++k) {
    ChannelAdequacy& c = adequacy->channels[k];
    if (!c.used) continue;
    double sum = 0;
    long count = 0;
    for (size_t l = 0; l < logs.size(); ++l) {
      for (double e : ObservedSeries(logs[l], error[l], k)) {
        sum += e * e;
        ++count;
      }
    }
    c.discretisation = count > 0 ? std::sqrt(sum / count) : 0;
    adequacy->discretisation =
        std::max(adequacy->discretisation, c.discretisation);
  }
}

Adequacy BetterOfStepAndLimit(
    Adequacy at_step, Adequacy limit, const std::vector<Experiment>& logs,
    const std::vector<std::vector<Vec6<double>>>& discretisation) {
  limit.continuous_limit = true;
  Adequacy& better = limit.chi_square < at_step.chi_square ? limit : at_step;
  AddDiscretisationError(logs, discretisation, &better);
  return better;
}

double LjungBox(const std::vector<double>& x, int lags) {
  const size_t n = x.size();
  if (n <= static_cast<size_t>(lags)) return 0;
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

double ChiSquareUpperTail(double x, double dof) {
  if (!(dof > 0)) return 1.0;  // no degrees of freedom: no evidence
  if (!(x < std::numeric_limits<double>::infinity())) return 0.0;  // inf, NaN
  return UpperIncompleteGamma(0.5 * dof, 0.5 * x);
}

double WhitenessP(const std::vector<Experiment>& logs,
                  const std::vector<std::vector<Vec6<double>>>& weighted,
                  const std::vector<int>& channels, int lags) {
  double min_p = 1;
  for (size_t l = 0; l < logs.size(); ++l) {
    for (int k : channels) {
      const double q = LjungBox(ObservedSeries(logs[l], weighted[l], k), lags);
      min_p = std::min(min_p, ChiSquareUpperTail(q, lags));
    }
  }
  return std::min(1.0, min_p * static_cast<double>(channels.size()) *
                           static_cast<double>(logs.size()));
}

Adequacy AssessAdequacy(const std::vector<Experiment>& logs,
                        const std::vector<std::vector<Vec6<double>>>& weighted,
                        const std::vector<int>& channels, int fitted_parameters,
                        const AdequacyOptions& options) {
  Adequacy a;
  a.assessed = true;
  long residuals = 0;
  double min_p_overall = 1;
  for (int k : channels) {
    ChannelAdequacy& c = a.channels[k];
    c.used = true;
    double sum = 0;
    double min_p = 1;
    for (size_t l = 0; l < logs.size(); ++l) {
      const std::vector<double> x = ObservedSeries(logs[l], weighted[l], k);
      for (double r : x) sum += r * r;
      c.samples += static_cast<long>(x.size());
      min_p = std::min(min_p,
                       ChiSquareUpperTail(LjungBox(x, options.ljung_box_lags),
                                          options.ljung_box_lags));
    }
    c.score = c.samples > 0 ? sum / static_cast<double>(c.samples) : 0;
    c.whiteness_p = std::min(1.0, min_p * static_cast<double>(logs.size()));
    min_p_overall = std::min(min_p_overall, min_p);
    a.chi_square += sum;
    residuals += c.samples;
  }
  a.dof = static_cast<double>(residuals - fitted_parameters);
  a.score = residuals > 0 ? a.chi_square / static_cast<double>(residuals) : 0;
  // Bonferroni over every channel of every log, as WhitenessP.
  a.whiteness_p =
      std::min(1.0, min_p_overall * static_cast<double>(channels.size()) *
                        static_cast<double>(logs.size()));
  Decide(options, &a);
  return a;
}

Adequacy AssessPrediction(
    const std::vector<Experiment>& logs,
    const std::vector<std::vector<Vec6<double>>>& predicted,
    const std::vector<std::vector<Vec6<double>>>& decorrelated,
    const std::vector<int>& channels, const AdequacyOptions& options) {
  Adequacy a = AssessAdequacy(logs, decorrelated, channels, 0, options);
  // The chi-square r . (I + J C J^T)^-1 r, and the raw prediction's scores.
  double chi_square = 0, raw = 0;
  Vec6<double> raw_per_channel = Vec6<double>::Zero();
  for (size_t l = 0; l < logs.size(); ++l) {
    for (size_t j = 0; j < predicted[l].size(); ++j) {
      if (!Observed(logs[l], j)) continue;
      for (int k : channels) {
        chi_square += predicted[l][j](k) * decorrelated[l][j](k);
        raw_per_channel(k) += predicted[l][j](k) * predicted[l][j](k);
      }
    }
  }
  long residuals = 0;
  for (int k : channels) {
    ChannelAdequacy& c = a.channels[k];
    c.score = c.samples > 0 ? raw_per_channel(k) / c.samples : 0;
    raw += raw_per_channel(k);
    residuals += c.samples;
  }
  a.chi_square = chi_square;
  a.score = residuals > 0 ? raw / static_cast<double>(residuals) : 0;
  Decide(options, &a);
  return a;
}

}  // namespace kcrig
