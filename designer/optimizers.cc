#include "designer/optimizers.h"

namespace kcrig {

const std::vector<std::string>& OptimizerNames() {
  static const std::vector<std::string> names = {
      "imfil",       "kriging",      "nlopt:direct-l",
      "nlopt:crs2",  "nlopt:bobyqa", "nlopt:cobyla",
      "nlopt:slsqp", "nlopt:mma",    "grid"};
  return names;
}

Status ValidateOptimizerName(const std::string& optimizer) {
  std::string list;
  for (const std::string& name : OptimizerNames()) {
    if (name == optimizer) return Status::Ok();
    list += (list.empty() ? "" : ", ") + name;
  }
  return Status::Error("--optimizer " + optimizer + ": unknown (" + list + ")");
}

Status Optimize(const std::string& optimizer, DesignObjective* objective,
                const Design& start, const OptimizerOptions& options,
                OptimizationResult* result) {
  const Status name = ValidateOptimizerName(optimizer);
  if (!name.ok()) return name;
  const DesignBounds& b = objective->bounds();
  if (!(start.phi >= b.phi.lower && start.phi <= b.phi.upper &&
        start.z_a >= b.z_a.lower && start.z_a <= b.z_a.upper)) {
    return Status::Error("design: the start design lies outside the bounds");
  }
  *result = OptimizationResult();
  result->optimizer = optimizer;
  result->start = start;
  const std::vector<DesignEvaluation> first =
      objective->Evaluate({objective->ToUnit(start)});
  result->start_value = first.front().value;
  result->path.push_back(start);

  Status status;
  if (optimizer == "grid") {
    status = GridSearch(objective, options, result);
  } else if (optimizer == "imfil") {
    status = ImplicitFiltering(objective, options, result);
  } else if (optimizer == "kriging") {
    status = KrigingSearch(objective, options, result);
  } else {
    status = NloptSearch(optimizer.substr(6), objective, options, result);
  }
  if (objective->interrupted()) return Interrupted("design");
  if (!status.ok()) return status;
  const DesignEvaluation& best = objective->best();
  result->best = best.design;
  result->best_value = best.value;
  result->best_singular = best.singular;
  result->evaluations = static_cast<int>(objective->record().size());
  result->seconds = objective->elapsed_seconds();
  result->budget_exhausted = objective->remaining() <= 0;
  return Status::Ok();
}

}  // namespace kcrig
