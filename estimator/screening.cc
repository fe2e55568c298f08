#include "estimator/screening.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>

#include "Eigen/Cholesky"
#include "Eigen/QR"
#include "estimator/internal/fit_problem.h"

namespace kcrig {

namespace {

Status CheckScreeningOptions(const ScreeningOptions& options) {
  if (!(options.range_low > 0 && options.range_low < 1.0 &&
        options.range_high > 1.0)) {
    return Status::Error("screening range must satisfy 0 < low < 1 < high");
  }
  if (options.levels < 2 || options.trajectories < 2) {
    return Status::Error("screening needs >= 2 levels and >= 2 trajectories");
  }
  return Status::Ok();
}

// Morris trajectories on the unit cube, u in {0, 1/(L-1), ..., 1}, with the
// usual step Delta = L / (2 (L - 1)); u maps to the scaled value
// low * (high / low)^u, so effects are per unit of log-range. Returns the
// elementary effects of each candidate.
Status MorrisEffects(FitProblem* problem, const ScreeningOptions& options,
                     int k, std::vector<std::vector<double>>* effects,
                     int* evaluations) {
  const int levels = options.levels;
  const double delta = levels / (2.0 * (levels - 1));
  const int base_levels = levels / 2;  // starts where u + Delta <= 1 fits
  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<int> pick_level(0, base_levels - 1);
  auto cost_at = [&](const std::vector<double>& u, double* cost) {
    std::vector<double> scaled(k);
    for (int i = 0; i < k; ++i) {
      scaled[i] = options.range_low *
                  std::pow(options.range_high / options.range_low, u[i]);
    }
    ++*evaluations;
    if (problem->Evaluate(scaled, cost, nullptr, nullptr)) return Status::Ok();
    return Status::Error("screening: the model fails inside the range");
  };
  effects->assign(k, {});
  for (int t = 0; t < options.trajectories; ++t) {
    std::vector<double> u(k);
    for (int i = 0; i < k; ++i) {
      u[i] = pick_level(rng) / static_cast<double>(levels - 1);
    }
    std::vector<int> order(k);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    double previous = 0;
    KCRIG_RETURN_IF_ERROR(cost_at(u, &previous));
    for (int i : order) {
      u[i] += delta;
      double cost = 0;
      KCRIG_RETURN_IF_ERROR(cost_at(u, &cost));
      (*effects)[i].push_back((cost - previous) / delta);
      previous = cost;
    }
    if (!options.callback) continue;
    IterationSummary summary;
    summary.stage = "screening";
    summary.done = *evaluations;
    summary.total = options.trajectories * (k + 1);
    summary.fraction = static_cast<double>(summary.done) / summary.total;
    if (options.callback(summary) == CallbackReturn::kAbort) {
      return Interrupted("screening");
    }
  }
  return Status::Ok();
}

// mu*, mu and sigma of each candidate's effects (in the given order), and
// which ones are negligible beside the largest mu*.
std::vector<ScreenedParameter> RankImpact(
    const std::vector<std::vector<double>>& effects,
    const ScreeningOptions& options) {
  std::vector<ScreenedParameter> ranking;
  for (size_t i = 0; i < effects.size(); ++i) {
    ScreenedParameter p;
    p.name = options.parameters[i];
    double sum = 0, sum_abs = 0;
    for (double e : effects[i]) {
      sum += e;
      sum_abs += std::abs(e);
    }
    const double count = static_cast<double>(effects[i].size());
    p.mu = sum / count;
    p.mu_star = sum_abs / count;
    double variance = 0;
    for (double e : effects[i]) variance += (e - p.mu) * (e - p.mu);
    p.sigma = std::sqrt(variance / std::max(1.0, count - 1));
    ranking.push_back(p);
  }
  double largest = 0;
  for (const ScreenedParameter& p : ranking) {
    largest = std::max(largest, p.mu_star);
  }
  for (ScreenedParameter& p : ranking) {
    p.negligible = p.mu_star < options.negligible_fraction * largest;
  }
  return ranking;
}

// Correlation of the centred sensitivity columns; pairs beyond the
// threshold are dependent.
void FindDependentPairs(const Eigen::MatrixXd& jacobian,
                        const ScreeningOptions& options,
                        ScreeningResult* result) {
  const int k = static_cast<int>(jacobian.cols());
  const Eigen::MatrixXd centered =
      jacobian.rowwise() - jacobian.colwise().mean();
  const Eigen::VectorXd norms = centered.colwise().norm();
  result->sensitivity_correlation.setIdentity(k, k);
  for (int i = 0; i < k; ++i) {
    for (int j = i + 1; j < k; ++j) {
      const double c =
          norms(i) > 0 && norms(j) > 0
              ? centered.col(i).dot(centered.col(j)) / (norms(i) * norms(j))
              : 0.0;
      result->sensitivity_correlation(i, j) = c;
      result->sensitivity_correlation(j, i) = c;
      if (std::abs(c) > options.dependence_correlation) {
        result->dependent_pairs.emplace_back(options.parameters[i],
                                             options.parameters[j]);
      }
    }
  }
}

// Estimable subset: pivot order of the non-negligible columns, longest
// leading set whose standard errors (at the stated sigmas) stay within the
// estimator's practical limit. `ranking` is still in the given order.
std::vector<std::string> EstimableSubset(
    const Eigen::MatrixXd& jacobian,
    const std::vector<ScreenedParameter>& ranking,
    double max_relative_standard_error) {
  std::vector<int> candidates;
  for (size_t i = 0; i < ranking.size(); ++i) {
    if (!ranking[i].negligible) candidates.push_back(static_cast<int>(i));
  }
  Eigen::MatrixXd reduced(jacobian.rows(), candidates.size());
  for (size_t c = 0; c < candidates.size(); ++c) {
    reduced.col(c) = jacobian.col(candidates[c]);
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(reduced);
  std::vector<int> pivot_order;
  for (int c = 0; c < static_cast<int>(candidates.size()); ++c) {
    pivot_order.push_back(candidates[qr.colsPermutation().indices()(c)]);
  }
  size_t accepted = 0;
  for (size_t m = 1; m <= pivot_order.size(); ++m) {
    Eigen::MatrixXd subset(jacobian.rows(), m);
    for (size_t c = 0; c < m; ++c) subset.col(c) = jacobian.col(pivot_order[c]);
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(subset.transpose() * subset);
    if (ldlt.info() != Eigen::Success) break;
    const Eigen::MatrixXd inverse = ldlt.solve(Eigen::MatrixXd::Identity(m, m));
    bool all_within = inverse.diagonal().minCoeff() > 0;
    for (size_t c = 0; c < m && all_within; ++c) {
      all_within = std::sqrt(inverse(c, c)) <= max_relative_standard_error;
    }
    if (all_within) accepted = m;
  }
  std::vector<std::string> estimable;
  for (size_t c = 0; c < accepted; ++c) {
    estimable.push_back(ranking[pivot_order[c]].name);
  }
  return estimable;
}

}  // namespace

Status Screen(const SuspensionParameters<double>& nominal,
              const std::vector<Experiment>& experiments,
              const EstimatorOptions& estimator_options,
              const ScreeningOptions& options, double integrator_step,
              ScreeningResult* result) {
  const auto start = std::chrono::steady_clock::now();
  KCRIG_RETURN_IF_ERROR(CheckScreeningOptions(options));
  std::vector<int> indices;
  KCRIG_RETURN_IF_ERROR(
      ResolveParameters(nominal, options.parameters, &indices));
  const int k = static_cast<int>(indices.size());
  EstimatorOptions fit_options = estimator_options;
  fit_options.parameters = options.parameters;
  fit_options.lower_scale =
      std::min(fit_options.lower_scale, options.range_low);
  fit_options.upper_scale =
      std::max(fit_options.upper_scale, options.range_high);
  KCRIG_RETURN_IF_ERROR(CheckFitMemory(experiments, fit_options, k));
  FitProblem problem(nominal, experiments, fit_options, integrator_step,
                     indices);
  *result = ScreeningResult();
  result->names = options.parameters;

  std::vector<std::vector<double>> effects;
  KCRIG_RETURN_IF_ERROR(
      MorrisEffects(&problem, options, k, &effects, &result->evaluations));
  result->ranking = RankImpact(effects, options);

  // Dependence and estimability from the sensitivities at the nominal values.
  Eigen::MatrixXd jacobian;
  if (!problem.Evaluate(std::vector<double>(k, 1.0), nullptr, nullptr,
                        &jacobian)) {
    return Status::Error("screening: the model fails at the nominal values");
  }
  FindDependentPairs(jacobian, options, result);
  result->estimable = EstimableSubset(
      jacobian, result->ranking, estimator_options.max_relative_standard_error);

  std::stable_sort(result->ranking.begin(), result->ranking.end(),
                   [](const ScreenedParameter& a, const ScreenedParameter& b) {
                     return a.mu_star > b.mu_star;
                   });
  result->seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  return Status::Ok();
}

}  // namespace kcrig
