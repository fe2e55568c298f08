#include "diagnosis/internal/residual_statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace kcrig {
namespace {

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

double ChiSquareUpperTail(double x, double dof) {
  if (!(dof > 0)) return 1.0;  // no degrees of freedom: no evidence
  if (!(x < std::numeric_limits<double>::infinity())) return 0.0;  // inf, NaN
  return UpperIncompleteGamma(0.5 * dof, 0.5 * x);
}

}  // namespace kcrig
