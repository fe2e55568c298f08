#include "designer/campaign.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>

#include "base/json_reader.h"
#include "designer/design_step.h"
#include "estimator/estimate_io.h"
#include "estimator/experiment.h"
#include "nlohmann/json.hpp"
#include "records/run_log.h"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

bool WithinTarget(const EstimationResult& estimate, double target) {
  if (!(target > 0)) return false;
  for (const ParameterEstimate& p : estimate.parameters) {
    if (!p.identifiable) return false;
    const double half = 0.5 * (p.ci95_high - p.ci95_low);
    if (!(half <= target * std::abs(p.value))) return false;
  }
  return true;
}

// One parameter of campaign.json's iteration `where`: name and value
// required; unit, interval and log10 diag((J^T J)^-1) as written (null for
// what did not exist).
Status ReadParameter(const nlohmann::json& node, const std::string& where,
                     ParameterEstimate* p) {
  for (Status s : {ReadField(node, "name", where, &p->name),
                   ReadField(node, "value", where, &p->value)}) {
    if (!s.ok()) return s;
  }
  p->unit = node.value("unit", "");
  const nlohmann::json ci95 = node.value("ci95", nlohmann::json());
  p->identifiable = ci95.is_array() && ci95.size() == 2 &&
                    ci95[0].is_number() && ci95[1].is_number();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  p->ci95_low = p->identifiable ? ci95[0].get<double>() : nan;
  p->ci95_high = p->identifiable ? ci95[1].get<double>() : nan;
  const nlohmann::json log10 =
      node.value("log10_diag_inv_jtj", nlohmann::json());
  p->log10_inverse_information = log10.is_number() ? log10.get<double>() : nan;
  return Status::Ok();
}

Status ReadIteration(const nlohmann::json& node, const std::string& where,
                     CampaignIteration* it) {
  nlohmann::json experiment;
  std::vector<nlohmann::json> parameters;
  double phi_deg = 0;
  for (Status s :
       {ReadField(node, "iteration", where, &it->index),
        ReadField(node, "experiment", where, &experiment),
        ReadField(node, "parameters", where, &parameters),
        ReadField(experiment, "phi_deg", where + ".experiment", &phi_deg),
        ReadField(experiment, "z_a", where + ".experiment",
                  &it->experiment.z_a)}) {
    if (!s.ok()) return s;
  }
  it->experiment.phi = phi_deg * kDegree;
  it->logs = node.value("logs", std::vector<std::string>());
  it->criterion_of_data = node.value("criterion_of_data", 0.0);
  it->designed = node.contains("next_design");
  for (size_t i = 0; i < parameters.size(); ++i) {
    KCRIG_RETURN_IF_ERROR(ReadParameter(
        parameters[i], where + ".parameters[" + std::to_string(i) + "]",
        &it->estimate.parameters.emplace_back()));
  }
  return Status::Ok();
}

Status ReadCampaignJson(const std::string& out_dir, Criterion* criterion,
                        std::vector<CampaignIteration>* iterations) {
  const std::string file =
      (std::filesystem::path(out_dir) / "campaign.json").string();
  nlohmann::json doc;
  KCRIG_RETURN_IF_ERROR(ReadJsonFile(file, &doc));
  std::string name;
  std::vector<nlohmann::json> list;
  for (Status s : {ReadField(doc, "criterion", file, &name),
                   ReadField(doc, "iterations", file, &list)}) {
    if (!s.ok()) return s;
  }
  const Status parsed = ParseCriterion(name, criterion);
  if (!parsed.ok()) return Status::Error(file + ": " + parsed.message());
  if (list.empty()) return Status::Error(file + ": iterations: no iteration");
  iterations->clear();
  for (size_t k = 0; k < list.size(); ++k) {
    CampaignIteration& it = iterations->emplace_back();
    KCRIG_RETURN_IF_ERROR(ReadIteration(
        list[k], file + ": iterations[" + std::to_string(k) + "]", &it));
    if (!it.designed) continue;
    // A campaign's design.json holds its one run.
    const std::string design =
        (std::filesystem::path(CampaignIterationDir(out_dir, it.index)) /
         "design.json")
            .string();
    Criterion designed = Criterion::kD;
    std::vector<DesignRun> runs;
    KCRIG_RETURN_IF_ERROR(ReadDesign(design, &designed, &runs));
    if (runs.empty()) return Status::Error(design + ": runs: no run");
    it.design = runs[BestRun(runs)];
  }
  return Status::Ok();
}

}  // namespace

Status ValidateCampaignOptions(const KcrigConfig& config,
                               const CampaignOptions& options) {
  if (options.iterations < 0) {
    return Status::Error("--iterations: must be >= 0");
  }
  if (!(options.target_relative_halfwidth >= 0) ||
      !std::isfinite(options.target_relative_halfwidth)) {
    return Status::Error("--target-halfwidth: must be finite and >= 0 %");
  }
  Status status = ValidateOptimizerName(options.optimizer);
  if (!status.ok()) return status;
  const DesignBounds bounds{config.experiment.phi_bounds,
                            config.experiment.z_a_bounds};
  status = DesignObjective::Validate(bounds, options.objective);
  if (!status.ok()) return status;
  std::vector<int> indices;
  return ResolveParameters(config.model, options.estimator.parameters,
                           &indices);
}

Status RunCampaign(const KcrigConfig& config, const CampaignOptions& options,
                   const RigRunner& rig, const std::string& out_dir,
                   std::vector<CampaignIteration>* iterations) {
  namespace fs = std::filesystem;
  iterations->clear();
  Status status = ValidateCampaignOptions(config, options);
  if (!status.ok()) return status;
  const DesignBounds bounds{config.experiment.phi_bounds,
                            config.experiment.z_a_bounds};
  std::vector<int> indices;
  status =
      ResolveParameters(config.model, options.estimator.parameters, &indices);
  if (!status.ok()) return status;
  ProgressReporter progress(options.callback);
  auto stage = [&progress](const std::string& text) {
    return progress.Report({text}) ? Status::Ok() : Interrupted("campaign");
  };
  EstimatorOptions estimator = options.estimator;
  estimator.callback = progress.Nested();

  std::vector<double> current = ParameterValues(config.model, indices);
  Design design{config.experiment.phi, config.experiment.z_a};
  std::vector<std::string> logs;
  std::vector<Experiment> experiments;  // one per log, in order
  for (int k = 0; k <= options.iterations; ++k) {
    CampaignIteration it;
    it.index = k;
    it.experiment = design;
    const fs::path dir = CampaignIterationDir(out_dir, k);
    std::error_code error;
    fs::create_directories(dir, error);
    if (error) {
      return Status::Error(dir.string() + ": cannot create (" +
                           error.message() + ")");
    }
    const std::string csv = (dir / "run.csv").string();
    char text[160];
    std::snprintf(text, sizeof(text),
                  "iteration %d: running the rig at phi %.2f deg, z_a %.3f m",
                  k, design.phi / kDegree, design.z_a);
    KCRIG_RETURN_IF_ERROR(stage(text));
    status = rig(config.experiment.Excitation(design.phi, design.z_a), k, csv);
    if (!status.ok()) return status;
    logs.push_back(csv);
    it.logs = logs;

    std::snprintf(text, sizeof(text), "iteration %d: estimating from %zu log%s",
                  k, logs.size(), logs.size() == 1 ? "" : "s");
    KCRIG_RETURN_IF_ERROR(stage(text));
    // Only the new log is read; the earlier ones are kept.
    status = LoadExperiment(csv, config, "", &experiments.emplace_back());
    if (!status.ok()) return status;
    status = Estimate(config.model, experiments, estimator, current,
                      config.experiment.step, &it.estimate);
    if (!status.ok()) return status;
    status =
        WriteFilesAtomically({{(dir / "est.json").string(),
                               EstimationResultToJson(it.estimate, logs, {})}});
    if (!status.ok()) return status;
    for (size_t i = 0; i < current.size(); ++i) {
      current[i] = it.estimate.parameters[i].value;
    }
    it.criterion_of_data =
        EvaluateCriterion(options.criterion, it.estimate.information).value;

    const bool done =
        k == options.iterations ||
        WithinTarget(it.estimate, options.target_relative_halfwidth);
    if (!done) {
      std::snprintf(text, sizeof(text), "iteration %d: designing (%s, %s)", k,
                    CriterionName(options.criterion),
                    options.optimizer.c_str());
      KCRIG_RETURN_IF_ERROR(stage(text));
      DesignStepOptions step;
      step.names = options.estimator.parameters;
      step.values = current;
      step.prior_information = it.estimate.information;
      step.criterion = options.criterion;
      step.optimizer = options.optimizer;
      step.objective = options.objective;
      const std::string designing = text;
      step.objective.callback = [&](const IterationSummary& batch) {
        return progress.Report(
                   {designing + " | " + options.optimizer + ": " + batch.stage,
                    batch.fraction, batch.done, batch.total})
                   ? CallbackReturn::kContinue
                   : CallbackReturn::kAbort;
      };
      step.optimizer_options = options.optimizer_options;
      const Design start{
          std::clamp(design.phi, bounds.phi.lower, bounds.phi.upper),
          std::clamp(design.z_a, bounds.z_a.lower, bounds.z_a.upper)};
      status = DesignStep(config, step, start, &it.design);
      if (!status.ok()) return status;
      it.designed = true;
      status = WriteFilesAtomically(
          {{(dir / "design.json").string(),
            DesignRunsToJson(options.criterion, {it.design})}});
      if (!status.ok()) return status;
      design = it.design.result.best;
    }
    if (options.on_iteration) options.on_iteration(it);
    iterations->push_back(std::move(it));
    if (done) break;
  }
  return Status::Ok();
}

std::string CampaignToJson(Criterion criterion,
                           const std::vector<CampaignIteration>& iterations) {
  nlohmann::ordered_json doc;
  doc["format"] = "kcrig campaign 1";
  doc["criterion"] = CriterionName(criterion);
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const CampaignIteration& it : iterations) {
    nlohmann::ordered_json parameters = nlohmann::ordered_json::array();
    for (const ParameterEstimate& p : it.estimate.parameters) {
      parameters.push_back(
          {{"name", p.name},
           {"unit", p.unit},
           {"value", p.value},
           {"ci95", p.identifiable
                        ? nlohmann::ordered_json{p.ci95_low, p.ci95_high}
                        : nlohmann::ordered_json()},
           {"log10_diag_inv_jtj", p.log10_inverse_information}});
    }
    nlohmann::ordered_json entry = {
        {"iteration", it.index},
        {"logs", it.logs},
        {"experiment",
         {{"phi_deg", it.experiment.phi / kDegree},
          {"z_a", it.experiment.z_a}}},
        {"parameters", parameters},
        {"criterion_of_data", it.criterion_of_data}};
    if (it.designed) {
      const OptimizationResult& r = it.design.result;
      entry["next_design"] = {{"optimizer", r.optimizer},
                              {"phi_deg", r.best.phi / kDegree},
                              {"z_a", r.best.z_a},
                              {"criterion_at_start", r.start_value},
                              {"criterion_at_optimum", r.best_value},
                              {"evaluations", r.evaluations},
                              {"seconds", r.seconds}};
    }
    list.push_back(entry);
  }
  doc["iterations"] = list;
  return doc.dump(2) + "\n";
}

std::string CampaignIterationDir(const std::string& out_dir, int index) {
  return (std::filesystem::path(out_dir) /
          ("iteration_" + std::to_string(index)))
      .string();
}

Status ReadCampaign(const std::string& out_dir, Criterion* criterion,
                    std::vector<CampaignIteration>* iterations) {
  const std::string file =
      (std::filesystem::path(out_dir) / "campaign.json").string();
  return GuardedRead(
      file, [&] { return ReadCampaignJson(out_dir, criterion, iterations); });
}

std::string CampaignIterationSummary(const CampaignIteration& it,
                                     Criterion criterion) {
  char line[256];
  std::string out;
  std::snprintf(line, sizeof(line),
                "== iteration %d: experiment phi %.2f deg, z_a %.3f m; "
                "estimate from %zu log%s ==\n",
                it.index, it.experiment.phi / kDegree, it.experiment.z_a,
                it.logs.size(), it.logs.size() == 1 ? "" : "s");
  out += line;
  out += EstimationSummary(it.estimate, {});
  std::snprintf(line, sizeof(line), "  criterion %s of the data so far: %.6g\n",
                CriterionName(criterion), it.criterion_of_data);
  out += line;
  if (it.designed) {
    const OptimizationResult& r = it.design.result;
    std::snprintf(line, sizeof(line),
                  "  next experiment: phi %.2f deg, z_a %.3f m (%s: %s %.6g "
                  "-> %.6g with it, %d evaluations, %.1f s)\n",
                  r.best.phi / kDegree, r.best.z_a, r.optimizer.c_str(),
                  CriterionName(criterion), r.start_value, r.best_value,
                  r.evaluations, r.seconds);
    out += line;
  }
  return out;
}

}  // namespace kcrig
