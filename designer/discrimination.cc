#include "designer/discrimination.h"

#include <cmath>
#include <cstdio>

#include "designer/internal/shape_search.h"
#include "nlohmann/json.hpp"
#include "rt_core/model/channels.h"
#include "rt_core/model/excitation.h"

namespace kcrig {
Status DesignDiscriminatingExperiment(const EffectModel& a,
                                      const std::vector<double>& values_a,
                                      const EffectModel& b,
                                      const std::vector<double>& values_b,
                                      const ExperimentConfig& experiment,
                                      const DiscriminationOptions& options,
                                      DiscriminatingDesign* design) {
  *design = DiscriminatingDesign();
  design->model_a = a.Name();
  design->model_b = b.Name();
  Status failure = Status::Ok();
  auto divergence = [&](const RampExcitation<double>& ramp) {
    const Experiment e = PlannedExperiment(ramp, experiment);
    std::vector<Vec6<double>> ya, yb;
    Status status = SimulateEffectModel(a, values_a, e, experiment.step, &ya);
    if (status.ok()) {
      status = SimulateEffectModel(b, values_b, e, experiment.step, &yb);
    }
    if (!status.ok()) {
      failure = status;
      return std::nan("");
    }
    double t = 0;
    for (size_t j = 0; j < ya.size(); ++j) {
      t += (ya[j] - yb[j]).cwiseQuotient(e.sigma).squaredNorm();
    }
    return t;
  };
  const ShapeSearchResult found = MaximizeOverShapes(
      experiment, options.shapes, options.evaluations_per_shape, divergence);
  design->evaluations = found.evaluations;
  if (found.value < 0) {
    return failure.ok() ? Status::Error(
                              "discriminating design: no design "
                              "could be evaluated")
                        : failure;
  }
  design->excitation = found.best;
  design->divergence = found.value;
  return Status::Ok();
}

std::string RunOptions(const RampExcitation<double>& d) {
  char options[200];
  std::snprintf(options, sizeof(options),
                "--phi %.2f --z %.3f --fmax %.0f --duration %.2f --hold %.2f "
                "--return %.2f",
                d.phi / kDegree, d.z_a, d.fmax, d.duration, d.hold,
                d.return_duration);
  return options;
}

std::string DiscriminatingDesignToJson(const DiscriminatingDesign& design) {
  const RampExcitation<double>& d = design.excitation;
  nlohmann::ordered_json doc = {
      {"discriminates", {design.model_a, design.model_b}},
      {"criterion", "sum of squared prediction differences / sigma^2"},
      {"phi_deg", d.phi / kDegree},
      {"z_a_m", d.z_a},
      {"fmax_n", d.fmax},
      {"tf_s", d.duration},
      {"hold_s", d.hold},
      {"return_s", d.return_duration},
      {"divergence", design.divergence},
      {"evaluations", design.evaluations},
      {"run_options", RunOptions(d)}};
  return doc.dump();
}

Status DesignToTellApart(const KcrigConfig& config,
                         const DiagnosisOptions& options,
                         const DiagnosisResult& result,
                         const std::string& model_a, const std::string& model_b,
                         DiscriminatingDesign* design) {
  EffectModel models[2];
  std::vector<double> values[2];
  const std::string names[2] = {model_a, model_b};
  for (int i = 0; i < 2; ++i) {
    Status status = EffectModel::CreateNamed(
        config.model, names[i], options.estimator.lower_scale,
        options.estimator.upper_scale, &models[i]);
    if (!status.ok()) return status;
    for (const CandidateScore& s : result.ranking) {
      if (s.model == names[i]) values[i] = s.fit.values;
    }
  }
  return DesignDiscriminatingExperiment(models[0], values[0], models[1],
                                        values[1], config.experiment,
                                        DiscriminationOptions(), design);
}

}  // namespace kcrig
