#include "designer/design_io.h"

#include <cmath>
#include <cstdio>

#include "base/json_reader.h"
#include "nlohmann/json.hpp"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

nlohmann::ordered_json Point(const Design& d, double value) {
  return {{"phi_deg", d.phi / kDegree}, {"z_a", d.z_a}, {"value", value}};
}

// A design and its value, {"phi_deg", "z_a", "value"}, at `node[key]`.
Status ReadPoint(const nlohmann::json& node, const std::string& key,
                 const std::string& where, Design* design, double* value) {
  nlohmann::json point;
  double phi_deg = 0;
  const std::string at = where + "." + key;
  for (Status s : {ReadField(node, key, where, &point),
                   ReadField(point, "phi_deg", at, &phi_deg),
                   ReadField(point, "z_a", at, &design->z_a),
                   ReadField(point, "value", at, value)}) {
    if (!s.ok()) return s;
  }
  design->phi = phi_deg * kDegree;
  return Status::Ok();
}

// Rows of `width` finite numbers at `node[key]`.
Status ReadRows(const nlohmann::json& node, const std::string& key,
                const std::string& where, size_t width,
                std::vector<std::vector<double>>* rows) {
  Status status = ReadField(node, key, where, rows);
  if (!status.ok()) return status;
  for (size_t r = 0; r < rows->size(); ++r) {
    const std::vector<double>& row = (*rows)[r];
    bool finite = row.size() == width;
    for (double v : row) finite = finite && std::isfinite(v);
    if (!finite) {
      return Status::Error(where + "." + key + "[" + std::to_string(r) +
                           "]: expected " + std::to_string(width) +
                           " finite numbers");
    }
  }
  return Status::Ok();
}

Status ReadRun(const nlohmann::json& node, const std::string& where,
               DesignRun* run) {
  OptimizationResult& r = run->result;
  std::vector<std::vector<double>> path, evaluated;
  for (Status s :
       {ReadField(node, "optimizer", where, &r.optimizer),
        ReadPoint(node, "initial", where, &r.start, &r.start_value),
        ReadPoint(node, "optimal", where, &r.best, &r.best_value),
        ReadField(node, "evaluations", where, &r.evaluations),
        ReadField(node, "budget_exhausted", where, &r.budget_exhausted),
        ReadField(node, "message", where, &r.message),
        ReadRows(node, "path", where, 2, &path),
        ReadRows(node, "evaluated", where, 4, &evaluated)}) {
    if (!s.ok()) return s;
  }
  for (const std::vector<double>& row : path) {
    r.path.push_back({row[0] * kDegree, row[1]});
  }
  for (const std::vector<double>& row : evaluated) {
    DesignEvaluation& e = run->record.emplace_back();
    e.design = {row[0] * kDegree, row[1]};
    e.value = row[2];
    e.batch = static_cast<int>(row[3]);
  }
  return Status::Ok();
}

Status ReadDesignJson(const std::string& path, Criterion* criterion,
                      std::vector<DesignRun>* runs) {
  nlohmann::json doc;
  Status status = ReadJsonFile(path, &doc);
  if (!status.ok()) return status;
  std::string name;
  std::vector<nlohmann::json> list;
  for (Status s : {ReadField(doc, "criterion", path, &name),
                   ReadField(doc, "runs", path, &list)}) {
    if (!s.ok()) return s;
  }
  status = ParseCriterion(name, criterion);
  if (!status.ok()) return Status::Error(path + ": " + status.message());
  runs->clear();
  for (size_t k = 0; k < list.size(); ++k) {
    status = ReadRun(list[k], path + ": runs[" + std::to_string(k) + "]",
                     &runs->emplace_back());
    if (!status.ok()) return status;
  }
  if (runs->empty()) return Status::Ok();
  return ReadField(doc, "optimal_singular", path,
                   &(*runs)[BestRun(*runs)].result.best_singular);
}

}  // namespace

Status ReadDesign(const std::string& path, Criterion* criterion,
                  std::vector<DesignRun>* runs) {
  return GuardedRead(path,
                     [&] { return ReadDesignJson(path, criterion, runs); });
}

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
