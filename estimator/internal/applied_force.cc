#include "estimator/internal/applied_force.h"

#include <algorithm>
#include <limits>

#include "Eigen/Dense"

namespace kcrig {
namespace {

// The least-squares FIR filter b (b[i] weighs u[t - i]) from u to y. The
// normal matrix is built in O(n * taps): its entries along a diagonal
// differ by one product each. A tiny ridge keeps a command that is zero
// throughout (the filter then is zero too).
Eigen::VectorXd FitFir(const Eigen::VectorXd& u, const Eigen::VectorXd& y,
                       int taps) {
  const Eigen::Index n = u.size();
  Eigen::MatrixXd normal(taps, taps);
  Eigen::VectorXd right(taps);
  for (int k = 0; k < taps; ++k) {
    // S(0, k) = sum over t >= k of u[t] u[t - k].
    normal(0, k) = u.tail(n - k).dot(u.head(n - k));
    right(k) = y.tail(n - k).dot(u.head(n - k));
  }
  // S(i + 1, k + 1) = S(i, k) - u[n - 1 - i] u[n - 1 - k].
  for (int i = 0; i + 1 < taps; ++i) {
    for (int k = i; k + 1 < taps; ++k) {
      normal(i + 1, k + 1) = normal(i, k) - u(n - 1 - i) * u(n - 1 - k);
    }
  }
  normal.triangularView<Eigen::StrictlyLower>() = normal.transpose();
  const double ridge =
      1e-12 * normal.trace() / taps + std::numeric_limits<double>::min();
  normal.diagonal().array() += ridge;
  return normal.ldlt().solve(right);
}

Eigen::VectorXd Differences(const Eigen::VectorXd& v) {
  return v.tail(v.size() - 1) - v.head(v.size() - 1);
}

Eigen::VectorXd Filtered(const Eigen::VectorXd& b, const Eigen::VectorXd& u) {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(u.size());
  for (Eigen::Index i = 0; i < b.size(); ++i) {
    out.tail(u.size() - i) += b(i) * u.head(u.size() - i);
  }
  return out;
}

Eigen::VectorXd CentredMean(const Eigen::VectorXd& r, int half_width) {
  const Eigen::Index n = r.size();
  Eigen::VectorXd sum(n + 1);
  sum(0) = 0;
  for (Eigen::Index j = 0; j < n; ++j) sum(j + 1) = sum(j) + r(j);
  Eigen::VectorXd out(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const Eigen::Index w = std::min<Eigen::Index>({half_width, j, n - 1 - j});
    out(j) = (sum(j + w + 1) - sum(j - w)) / static_cast<double>(2 * w + 1);
  }
  return out;
}

}  // namespace

std::vector<Vec3<double>> AppliedForce(
    const std::vector<Vec3<double>>& measured,
    const std::vector<Vec3<double>>& commanded, int taps, int half_width) {
  const Eigen::Index n = static_cast<Eigen::Index>(measured.size());
  taps = static_cast<int>(std::min<Eigen::Index>(taps, n));
  std::vector<Vec3<double>> applied(measured.size());
  if (n == 0 || taps < 1) return applied;
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::VectorXd y(n), u(n);
    for (Eigen::Index j = 0; j < n; ++j) {
      y(j) = measured[j](axis);
      u(j) = commanded[j](axis);
    }
    // Fitted to the changes from sample to sample: a slow force the command
    // does not explain barely changes between samples, so it cannot bend
    // the filter (the filter commutes with the difference).
    const Eigen::VectorXd b = n > taps
                                  ? FitFir(Differences(u), Differences(y), taps)
                                  : Eigen::VectorXd::Zero(taps);
    const Eigen::VectorXd response = Filtered(b, u);
    const Eigen::VectorXd slow = CentredMean(y - response, half_width);
    for (Eigen::Index j = 0; j < n; ++j) {
      applied[j](axis) = response(j) + slow(j);
    }
  }
  return applied;
}

}  // namespace kcrig
