#include "designer/kriging.h"

#include <cmath>
#include <limits>

#include "Eigen/Dense"
#include "nlopt.hpp"

namespace kcrig {

Eigen::RowVectorXd KrigingModel::Regressors(const Eigen::Vector2d& x) const {
  switch (options_.regression) {
    case KrigingRegression::kConstant:
      return Eigen::RowVectorXd::Ones(1);
    case KrigingRegression::kLinear: {
      Eigen::RowVectorXd f(3);
      f << 1, x(0), x(1);
      return f;
    }
    case KrigingRegression::kQuadratic: {
      Eigen::RowVectorXd f(6);
      f << 1, x(0), x(1), x(0) * x(0), x(0) * x(1), x(1) * x(1);
      return f;
    }
  }
  return Eigen::RowVectorXd::Ones(1);
}

bool KrigingModel::Build(const Eigen::Vector2d& theta) {
  const int m = static_cast<int>(x_.rows());
  Eigen::MatrixXd r(m, m);
  for (int i = 0; i < m; ++i) {
    r(i, i) = 1.0 + options_.nugget;
    for (int j = 0; j < i; ++j) {
      const Eigen::Vector2d d = x_.row(i) - x_.row(j);
      r(i, j) = r(j, i) = std::exp(-(theta.array() * d.array().square()).sum());
    }
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(r);
  if (llt.info() != Eigen::Success) return false;
  chol_l_ = llt.matrixL();
  Eigen::MatrixXd f(m, Regressors(Eigen::Vector2d::Zero()).size());
  for (int i = 0; i < m; ++i) f.row(i) = Regressors(x_.row(i).transpose());
  const auto lower = chol_l_.triangularView<Eigen::Lower>();
  f_tilde_ = lower.solve(f);
  const Eigen::VectorXd y_tilde = lower.solve(y_);
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(f_tilde_);
  const int p = static_cast<int>(f.cols());
  g_r_ = qr.matrixQR().topRows(p).triangularView<Eigen::Upper>();
  const Eigen::VectorXd qty = (qr.householderQ().transpose() * y_tilde).head(p);
  beta_ = g_r_.triangularView<Eigen::Upper>().solve(qty);
  const Eigen::VectorXd rho = y_tilde - f_tilde_ * beta_;
  sigma2_ = rho.squaredNorm() / m;
  gamma_ = chol_l_.transpose().triangularView<Eigen::Upper>().solve(rho);
  theta_ = theta;
  return beta_.allFinite() && std::isfinite(sigma2_);
}

double KrigingModel::LikelihoodObjective(const Eigen::Vector2d& theta) const {
  KrigingModel copy = *this;
  if (!copy.Build(theta)) return std::numeric_limits<double>::infinity();
  const double log_det = 2 * copy.chol_l_.diagonal().array().log().sum();
  return std::log(std::max(copy.sigma2_, 1e-300)) + log_det / x_.rows();
}

Status KrigingModel::Fit(const std::vector<Eigen::Vector2d>& x,
                         const std::vector<double>& y,
                         const KrigingOptions& options,
                         const Eigen::Vector2d* theta_start) {
  options_ = options;
  const int m = static_cast<int>(x.size());
  const int p = static_cast<int>(Regressors(Eigen::Vector2d::Zero()).size());
  if (m <= p || y.size() != x.size()) {
    return Status::Error("kriging: need more points than regression terms (" +
                         std::to_string(p) + ")");
  }
  x_.resize(m, 2);
  y_.resize(m);
  for (int i = 0; i < m; ++i) {
    x_.row(i) = x[i].transpose();
    y_(i) = y[i];
  }
  if (!y_.allFinite()) return Status::Error("kriging: non-finite data");
  y_mean_ = y_.mean();
  y_scale_ = std::sqrt((y_.array() - y_mean_).square().mean());
  if (!(y_scale_ > 0)) y_scale_ = 1;
  y_ = (y_.array() - y_mean_) / y_scale_;

  // Maximum likelihood in log theta: BOBYQA from a few starts.
  struct Data {
    const KrigingModel* model;
  } data{this};
  auto objective = [](unsigned, const double* v, double*, void* d) {
    const Data* data = static_cast<const Data*>(d);
    return data->model->LikelihoodObjective(
        Eigen::Vector2d(std::exp(v[0]), std::exp(v[1])));
  };
  std::vector<Eigen::Vector2d> starts = {Eigen::Vector2d(1, 1),
                                         Eigen::Vector2d(10, 10),
                                         Eigen::Vector2d(100, 100)};
  if (theta_start) starts.insert(starts.begin(), *theta_start);
  double best = std::numeric_limits<double>::infinity();
  Eigen::Vector2d best_theta = starts.front();
  const double lo = std::log(options.theta_lower);
  const double hi = std::log(options.theta_upper);
  for (const Eigen::Vector2d& start : starts) {
    nlopt::opt opt(nlopt::LN_BOBYQA, 2);
    opt.set_lower_bounds({lo, lo});
    opt.set_upper_bounds({hi, hi});
    opt.set_min_objective(objective, &data);
    opt.set_xtol_abs(1e-3);
    opt.set_maxeval(60);
    std::vector<double> v = {std::clamp(std::log(start(0)), lo, hi),
                             std::clamp(std::log(start(1)), lo, hi)};
    double value = std::numeric_limits<double>::infinity();
    try {
      opt.optimize(v, value);
    } catch (const std::exception&) {
      value = objective(2, v.data(), nullptr, &data);
    }
    if (value < best) {
      best = value;
      best_theta = Eigen::Vector2d(std::exp(v[0]), std::exp(v[1]));
    }
  }
  if (!std::isfinite(best) || !Build(best_theta)) {
    return Status::Error(
        "kriging: the correlation matrix is not positive definite for any "
        "theta (points too close together)");
  }
  return Status::Ok();
}

double KrigingModel::Predict(const Eigen::Vector2d& x, double* mse) const {
  const int m = static_cast<int>(x_.rows());
  Eigen::VectorXd r(m);
  for (int i = 0; i < m; ++i) {
    const Eigen::Vector2d d = x - x_.row(i).transpose();
    r(i) = std::exp(-(theta_.array() * d.array().square()).sum());
  }
  const Eigen::RowVectorXd f = Regressors(x);
  const double normalized = f.dot(beta_) + r.dot(gamma_);
  if (mse) {
    const auto lower = chol_l_.triangularView<Eigen::Lower>();
    const Eigen::VectorXd rt = lower.solve(r);
    const Eigen::VectorXd u =
        g_r_.triangularView<Eigen::Upper>().transpose().solve(
            f_tilde_.transpose() * rt - f.transpose());
    const double value =
        sigma2_ * (1.0 + options_.nugget + u.squaredNorm() - rt.squaredNorm());
    *mse = std::max(0.0, value) * y_scale_ * y_scale_;
  }
  return y_mean_ + y_scale_ * normalized;
}

Status RefitSurrogate(const std::vector<DesignEvaluation>& record,
                      Criterion criterion, const DesignBounds& bounds,
                      int batch, KrigingModel* model, int* samples) {
  std::vector<Eigen::Vector2d> x;
  std::vector<double> y;
  for (const DesignEvaluation& e : record) {
    if (e.batch > batch) continue;
    x.push_back(ToUnit(bounds, e.design));
    y.push_back(OptimizationScale(criterion, e.value));
  }
  *samples = static_cast<int>(x.size());
  return model->Fit(x, y, KrigingOptions());
}

double ExpectedImprovement(double best, double prediction, double mse) {
  const double s = std::sqrt(std::max(mse, 0.0));
  const double gap = best - prediction;
  if (s < 1e-12 * (1 + std::abs(best))) return std::max(gap, 0.0);
  const double z = gap / s;
  const double cdf = 0.5 * std::erfc(-z / std::sqrt(2.0));
  const double pdf = std::exp(-0.5 * z * z) / std::sqrt(2 * M_PI);
  return gap * cdf + s * pdf;
}

}  // namespace kcrig
