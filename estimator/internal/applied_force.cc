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

// The mean over 2 half_width + 1 samples around each, the window shifted
// inside the log at its ends: the first rows (the tare, from which a model
// settles) are averaged as much as the rest.
Eigen::VectorXd MovingMean(const Eigen::VectorXd& r, int half_width) {
  const Eigen::Index n = r.size();
  const Eigen::Index width = std::min<Eigen::Index>(2 * half_width + 1, n);
  Eigen::VectorXd sum(n + 1);
  sum(0) = 0;
  for (Eigen::Index j = 0; j < n; ++j) sum(j + 1) = sum(j) + r(j);
  Eigen::VectorXd out(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const Eigen::Index first =
        std::clamp<Eigen::Index>(j - half_width, 0, n - width);
    out(j) = (sum(first + width) - sum(first)) / static_cast<double>(width);
  }
  return out;
}

}  // namespace

std::vector<Vec3<double>> AppliedForce(
    const std::vector<Vec3<double>>& measured,
    const std::vector<Vec3<double>>& commanded, int taps, int half_width) {
  const Eigen::Index n = static_cast<Eigen::Index>(measured.size());
  if (n == 0 || commanded.size() != measured.size() || taps < 1 ||
      half_width < 0) {
    return measured;
  }
  std::vector<Vec3<double>> applied(measured.size());
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::VectorXd y(n), u(n);
    for (Eigen::Index j = 0; j < n; ++j) {
      y(j) = measured[j](axis);
      u(j) = commanded[j](axis);
    }
    // Fitted to the changes from sample to sample: a slow force the command
    // does not explain barely changes between samples, so it cannot bend
    // the filter. The filter then runs on the command's change since the
    // first sample (the command held before it, as the differences assume);
    // the mean puts back any constant, so its gain at rest does not matter.
    // (A log no longer than the filter: the mean alone.)
    Eigen::VectorXd response = Eigen::VectorXd::Zero(n);
    if (n > taps) {
      response = Filtered(FitFir(Differences(u), Differences(y), taps),
                          (u.array() - u(0)).matrix());
    }
    const Eigen::VectorXd slow = MovingMean(y - response, half_width);
    for (Eigen::Index j = 0; j < n; ++j) {
      applied[j](axis) = response(j) + slow(j);
    }
  }
  return applied;
}

}  // namespace kcrig
