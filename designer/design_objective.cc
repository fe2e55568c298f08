#include "designer/design_objective.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <utility>

#include "rt_core/model/channels.h"

namespace kcrig {

DesignObjective::DesignObjective(const InformationEvaluator* evaluator,
                                 Criterion criterion,
                                 const DesignBounds& bounds,
                                 ObjectiveOptions options)
    : evaluator_(evaluator),
      criterion_(criterion),
      bounds_(bounds),
      options_(std::move(options)),
      start_(std::chrono::steady_clock::now()) {}

Status DesignObjective::Validate(const DesignBounds& bounds,
                                 const ObjectiveOptions& options) {
  if (options.budget <= 0) {
    return Status::Error("--budget " + std::to_string(options.budget) +
                         ": must be at least 1 criterion evaluation");
  }
  if (options.num_threads < 1) {
    return Status::Error("design: num_threads must be >= 1");
  }
  return ValidateBounds(bounds);
}

Design DesignObjective::ToDesign(const Eigen::Vector2d& unit) const {
  const Eigen::Vector2d u = unit.cwiseMax(0.0).cwiseMin(1.0);
  return {bounds_.phi.lower + u(0) * (bounds_.phi.upper - bounds_.phi.lower),
          bounds_.z_a.lower + u(1) * (bounds_.z_a.upper - bounds_.z_a.lower)};
}

Eigen::Vector2d DesignObjective::ToUnit(const Design& design) const {
  return kcrig::ToUnit(bounds_, design);
}

Eigen::MatrixXd DesignObjective::InformationAt(
    const Eigen::Vector2d& unit) const {
  Eigen::MatrixXd information;
  // A diverged simulation carries no information (criteria.h penalty).
  if (!evaluator_->Information(ToDesign(unit), &information).ok()) {
    const int n = evaluator_->num_parameters();
    information = Eigen::MatrixXd::Constant(
        n, n, std::numeric_limits<double>::quiet_NaN());
  }
  return information;
}

DesignEvaluation DesignObjective::Evaluated(
    const Eigen::Vector2d& unit, const Eigen::MatrixXd& information) const {
  DesignEvaluation e;
  e.unit = unit;
  e.design = ToDesign(unit);
  e.information = information;
  const CriterionValue value = EvaluateCriterion(criterion_, e.information);
  e.value = value.value;
  e.singular = value.singular;
  e.epigraph = value.epigraph;
  return e;
}

std::vector<DesignEvaluation> DesignObjective::Evaluate(
    const std::vector<Eigen::Vector2d>& points) {
  std::vector<DesignEvaluation> results(points.size());
  std::vector<int> to_run;  // indices of points not in the record
  const int affordable = remaining();
  size_t count = 0;  // points answered: up to the first one not affordable
  for (; count < points.size(); ++count) {
    const Eigen::Vector2d u = points[count].cwiseMax(0.0).cwiseMin(1.0);
    const auto known =
        std::find_if(record_.begin(), record_.end(),
                     [&u](const DesignEvaluation& e) { return e.unit == u; });
    if (known != record_.end()) {
      results[count] = *known;
      continue;
    }
    if (static_cast<int>(to_run.size()) >= affordable) break;
    to_run.push_back(static_cast<int>(count));
    results[count].unit = u;
  }

  // The trajectories run in the batch; their information matrices (raw
  // doubles) come back to every rank, the criterion is evaluated here.
  std::vector<std::string> information;
  BatchesOr(options_.batches)
      .Run(
          static_cast<int>(to_run.size()), options_.num_threads,
          [&](int k, std::string* bytes) {
            const Eigen::MatrixXd matrix =
                InformationAt(results[to_run[k]].unit);
            bytes->assign(reinterpret_cast<const char*>(matrix.data()),
                          matrix.size() * sizeof(double));
          },
          &information);
  const int n = evaluator_->num_parameters();
  for (size_t k = 0; k < to_run.size(); ++k) {
    // A result of another size is not a matrix: no information.
    Eigen::MatrixXd matrix = Eigen::MatrixXd::Constant(
        n, n, std::numeric_limits<double>::quiet_NaN());
    if (information[k].size() == matrix.size() * sizeof(double)) {
      std::memcpy(matrix.data(), information[k].data(), information[k].size());
    }
    results[to_run[k]] = Evaluated(results[to_run[k]].unit, matrix);
  }

  for (int index : to_run) {
    results[index].batch = batches_;
    record_.push_back(results[index]);
  }
  if (!to_run.empty()) {
    ++batches_;
    interrupted_ = !ReportBatch();
  }
  results.resize(count);
  return results;
}

bool DesignObjective::ReportBatch() const {
  if (!options_.callback) return true;
  const DesignEvaluation& b = best();
  const int used = static_cast<int>(record_.size());
  const double seconds = elapsed_seconds();
  char text[200];
  std::snprintf(text, sizeof(text),
                "%d/%d evaluations, best %s %.6g at %.1f deg, %.3f m, %.1f s "
                "(at most %.0f s left)",
                used, budget(), CriterionName(criterion_), b.value,
                b.design.phi / kDegree, b.design.z_a, seconds,
                seconds / std::max(used, 1) * remaining());
  return options_.callback({text, static_cast<double>(used) / budget(), used,
                            budget()}) == CallbackReturn::kContinue;
}

const DesignEvaluation& DesignObjective::best() const {
  return *std::min_element(
      record_.begin(), record_.end(),
      [](const DesignEvaluation& a, const DesignEvaluation& b) {
        return a.value < b.value;
      });
}

double DesignObjective::elapsed_seconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                       start_)
      .count();
}

}  // namespace kcrig
