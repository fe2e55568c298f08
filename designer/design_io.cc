#include "designer/design_io.h"

#include <cmath>
#include <cstdio>

#include "nlohmann/json.hpp"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

nlohmann::ordered_json Point(const Design& d, double value) {
  return {{"phi_deg", d.phi / kDegree}, {"z_a", d.z_a}, {"value", value}};
}

}  // namespace

size_t BestRun(const std::vector<DesignRun>& runs) {
  size_t best = 0;
  for (size_t i = 1; i < runs.size(); ++i) {
    if (runs[i].result.best_value < runs[best].result.best_value) best = i;
  }
  return best;
}

std::string DesignRunsToJson(Criterion criterion,
                             const std::vector<DesignRun>& runs) {
  nlohmann::ordered_json doc;
  doc["format"] = "kcrig design 1";
  doc["criterion"] = CriterionName(criterion);
  if (!runs.empty()) {
    const OptimizationResult& best = runs[BestRun(runs)].result;
    doc["optimizer"] = best.optimizer;
    doc["initial"] = Point(best.start, best.start_value);
    doc["optimal"] = Point(best.best, best.best_value);
    doc["optimal_singular"] = best.best_singular;
    doc["evaluations"] = best.evaluations;
    doc["seconds"] = best.seconds;
  }
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const DesignRun& run : runs) {
    const OptimizationResult& r = run.result;
    nlohmann::ordered_json path = nlohmann::ordered_json::array();
    for (const Design& d : r.path) path.push_back({d.phi / kDegree, d.z_a});
    nlohmann::ordered_json evaluated = nlohmann::ordered_json::array();
    for (const DesignEvaluation& e : run.record) {
      evaluated.push_back(
          {e.design.phi / kDegree, e.design.z_a, e.value, e.batch});
    }
    list.push_back({{"optimizer", r.optimizer},
                    {"initial", Point(r.start, r.start_value)},
                    {"optimal", Point(r.best, r.best_value)},
                    {"evaluations", r.evaluations},
                    {"seconds", r.seconds},
                    {"budget_exhausted", r.budget_exhausted},
                    {"message", r.message},
                    {"path", path},
                    {"evaluated_columns", {"phi_deg", "z_a", "value", "batch"}},
                    {"evaluated", evaluated}});
  }
  doc["runs"] = list;
  return doc.dump(1) + "\n";
}

std::string ComparisonTable(Criterion criterion,
                            const std::vector<DesignRun>& runs) {
  std::string out;
  char line[256];
  std::snprintf(line, sizeof(line), "%-9s %13s  %-15s %13s %6s %8s %9s %8s\n",
                "criterion", "Phi(v0)", "algorithm", "Phi(v*)", "nEv",
                "wall [s]", "phi [deg]", "z_a [m]");
  out += line;
  for (const DesignRun& run : runs) {
    const OptimizationResult& r = run.result;
    std::snprintf(line, sizeof(line),
                  "%-9s %13.6g  %-15s %13.8g %6d %8.2f %9.2f %8.3f%s\n",
                  CriterionName(criterion), r.start_value, r.optimizer.c_str(),
                  r.best_value, r.evaluations, r.seconds, r.best.phi / kDegree,
                  r.best.z_a, r.budget_exhausted ? "  (budget spent)" : "");
    out += line;
  }
  return out;
}

}  // namespace kcrig
