#include "validation/validation.h"

#include <stdlib.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <system_error>

#include "Eigen/Cholesky"
#include "diagnosis/diagnosis_io.h"
#include "emulator/sil_rig.h"
#include "estimator/effect_model.h"
#include "hil/rig_session.h"
#include "nlohmann/json.hpp"

namespace kcrig {
namespace {

using Json = nlohmann::ordered_json;

// Effect sizes of the power curve's bins [noise units].
constexpr double kSizeBins[] = {0, 1, 2, 3, 5, 10, 30};
// Effects beyond this size are the ones the acceptance figures count.
constexpr double kLargeEffect = 3;

// The rig a case runs on: the configured rig (ValidationOptions::plant)
// with the case's truth in place of plant.yaml's (true parameters and
// effects, no sensor offset), the case's noise seed.
PlantConfig CasePlant(const KcrigConfig& config,
                      const ValidationOptions& options, const BlindCase& c,
                      bool noise) {
  PlantConfig plant = options.plant;
  plant.model = BlindCasePlant(c, config.model);
  plant.effects = c.effects;
  plant.sensor_offset.setZero();
  plant.noise = noise;
  plant.seed = c.noise_seed;
  return plant;
}

// A folder of one case's logs in the temporary folder, removed with this.
class CaseFolder {
 public:
  CaseFolder() = default;
  ~CaseFolder() {
    std::error_code ignored;
    if (!path_.empty()) std::filesystem::remove_all(path_, ignored);
  }
  CaseFolder(const CaseFolder&) = delete;
  CaseFolder& operator=(const CaseFolder&) = delete;

  Status Create() {
    std::error_code error;
    const auto temp = std::filesystem::temp_directory_path(error);
    if (error) {
      return Status::Error("no temporary folder (" + error.message() + ")");
    }
    std::string path = (temp / "kcrig_validate_XXXXXX").string();
    if (mkdtemp(path.data()) == nullptr) {
      return Status::Error("cannot create a folder in " + temp.string() + " (" +
                           std::strerror(errno) + ")");
    }
    path_ = path;
    return Status::Ok();
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// Log k of the case run on `sil` (the run after its last), into `dir`.
Status RecordLog(const KcrigConfig& config, const ValidationOptions& options,
                 const BlindCase& c, int k, const std::string& dir, SilRig* sil,
                 Experiment* experiment) {
  const int trained = static_cast<int>(c.training.size());
  RigSessionOptions run;
  run.excitation = (k < trained ? c.training[k] : c.holdout[k - trained])
                       .Ramp(config.experiment.fmax);
  run.log_dir = dir;
  run.clock = sil->clock();
  const std::unique_ptr<RigInterface> link = sil->Connect({});
  KCRIG_RETURN_IF_ERROR(link->Configure());
  RigSessionResult result;
  KCRIG_RETURN_IF_ERROR(
      RunRigSession(config, options.rig, link.get(), run, &result));
  if (!result.completed) return Status::Error(result.trip_message);
  KCRIG_RETURN_IF_ERROR(
      LoadExperiment(dir + "/run.csv", config, "", experiment));
  experiment->source =
      "case " + std::to_string(c.index) + " log " + std::to_string(k);
  return Status::Ok();
}

// The case's first `logs` designs (training, then hold-out) run back to
// back on the case's SIL rig, as the rig records them: its phases, its
// actuator and load cell, its memory from run to run. The rig's sidecar
// gets no truth, and the logs live only as long as this call.
Status RecordLogs(const KcrigConfig& config, const ValidationOptions& options,
                  const BlindCase& c, bool noise, int logs,
                  std::vector<Experiment>* experiments) {
  SilRig sil(config, CasePlant(config, options, c, noise));
  KCRIG_RETURN_IF_ERROR(sil.Start());
  CaseFolder folder;
  KCRIG_RETURN_IF_ERROR(folder.Create());
  experiments->resize(logs);
  for (int k = 0; k < logs; ++k) {
    const Status status = RecordLog(config, options, c, k,
                                    folder.path() + "/log_" + std::to_string(k),
                                    &sil, &(*experiments)[k]);
    if (!status.ok()) {
      return Status::Error("log " + std::to_string(k) +
                           " on the SIL rig: " + status.message());
    }
  }
  return Status::Ok();
}

// The ramps `designs` as the rig runs them (ValidateRunRequest); an error
// names `what`[i].
Status CheckRampsOnRig(const KcrigConfig& config, const RigConfig& rig,
                       const std::vector<BlindDesign>& designs,
                       const std::string& what) {
  for (size_t i = 0; i < designs.size(); ++i) {
    RigSessionOptions run;
    run.excitation = designs[i].Ramp(config.experiment.fmax);
    const Status status = ValidateRunRequest(rig, run);
    if (!status.ok()) {
      return Status::Error(what + "[" + std::to_string(i) +
                           "]: " + status.message());
    }
  }
  return Status::Ok();
}

// The effect's size in noise units (0 for a clean case).
Status EffectSize(const KcrigConfig& config, const ValidationOptions& options,
                  const BlindCase& c, double* size) {
  *size = 0;
  if (c.truth == "none") return Status::Ok();
  std::vector<Experiment> clean;
  KCRIG_RETURN_IF_ERROR(RecordLogs(config, options, c, /*noise=*/false,
                                   static_cast<int>(c.training.size()),
                                   &clean));
  return NominalFitSigmaHat(config, clean, size);
}

Json Designs(const std::vector<BlindDesign>& designs) {
  Json out = Json::array();
  for (const BlindDesign& d : designs) out.push_back(d.Arguments());
  return out;
}

// diag.json's field `name`, or `otherwise` when it is absent or null.
Json Field(const Json& diag, const char* name, Json otherwise) {
  return diag.contains(name) && !diag[name].is_null() ? diag[name] : otherwise;
}

// A set of components as the component confusion matrix labels it: the
// places joined by '+', "every bushing" for all five, "no component".
std::string ComponentLabel(const Json& components) {
  const auto bushings =
      std::count_if(components.begin(), components.end(), [](const Json& c) {
        return c.get<std::string>().rfind("bushing:", 0) == 0;
      });
  if (bushings == kNumBushings && components.size() == kNumBushings) {
    return "every bushing";
  }
  std::string label;
  for (const Json& c : components) {
    label += (label.empty() ? "" : "+") + c.get<std::string>();
  }
  return label.empty() ? "no component" : label;
}

// A coverage study: the 95 % intervals of the fitted stiffnesses against
// the rig's true ones, counted only for a correct verdict (whose fitted
// model is the truth's, the nominal one for a clean case); null otherwise.
Json StiffnessCoverage(const BlindCase& c, const Json& diag, bool correct) {
  if (!correct) return nullptr;
  const std::string model = Field(diag, "model", "");
  Json fitted = c.truth == "none" ? Field(diag, "nominal", nullptr) : nullptr;
  for (const Json& candidate : Field(diag, "candidates", Json::array())) {
    if (c.truth != "none" && candidate["model"] == model) fitted = candidate;
  }
  if (!fitted.is_object()) return nullptr;
  int inside = 0, total = 0;
  // Per stiffness, its error in half-widths of its interval (|z| > 1:
  // outside), to see how far the misses are.
  Json errors = Json::object();
  for (const auto& [name, value] : c.sets) {
    if (name.rfind("c_", 0) != 0) continue;
    for (const Json& p : fitted.value("parameters", Json::array())) {
      const Json& ci = p["ci95"];
      if (p["name"] != name || !ci[0].is_number() || !ci[1].is_number()) {
        continue;
      }
      const double low = ci[0], high = ci[1];
      ++total;
      inside += low <= value && value <= high;
      errors[name] = (value - (low + high) / 2) / ((high - low) / 2);
    }
  }
  return {{"inside", inside},
          {"total", total},
          {"widening", Field(fitted, "interval_widening", nullptr)},
          {"errors_in_halfwidths", errors}};
}

// Whether the case's moved hard point lies in the 95 % region of the
// diagnosis' move of it (quantification.hard_points); null without one.
Json PointMoveInRegion(const BlindCase& c, const Json& quantification) {
  for (const Json& fitted :
       Field(quantification, "hard_points", Json::array())) {
    if (fitted["point"] != c.parameter || fitted["covariance_m2"].is_null()) {
      continue;
    }
    Eigen::Matrix3d covariance;
    Eigen::Vector3d error;
    for (int j = 0; j < 3; ++j) {
      error(j) = c.point_move(j) - fitted["displacement_m"][j].get<double>();
      for (int k = 0; k < 3; ++k) {
        covariance(j, k) = fitted["covariance_m2"][j][k].get<double>();
      }
    }
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(covariance);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return nullptr;
    return error.dot(ldlt.solve(error)) <=
           fitted["region_chi2_95"].get<double>();
  }
  return nullptr;
}

// The diagnosis (diag.json's fields) against the case's truth.
Json Score(const BlindCase& c, double size, const Json& diag) {
  const std::string verdict = diag["verdict"];
  const std::string model = Field(diag, "model", "");
  const std::string confidence = Field(diag, "confidence", "");
  const Json ambiguous = Field(diag, "ambiguous", Json::array());
  const Json quantification = Field(diag, "quantification", Json::object());
  const std::string truth_model =
      c.parameter.empty() ? c.truth : "model_parameter@" + c.parameter;
  const bool correct =
      verdict == c.truth && (c.parameter.empty() || model == truth_model);
  Json out;
  out["index"] = c.index;
  out["truth"] = c.truth;
  out["truth_options"] = c.Arguments();
  out["magnitude"] = c.magnitude;
  out["designs"] = {{"training", Designs(c.training)},
                    {"holdout", Designs(c.holdout)}};
  out["size_sigma"] = size;
  out["verdict"] = verdict;
  out["column"] = verdict.find('+') != std::string::npos ? "pair" : verdict;
  out["model"] = model;
  out["confidence"] = confidence;
  out["components"] = Field(diag, "components", Json::array());
  out["truth_components"] = c.components;
  out["stiffness_coverage"] = StiffnessCoverage(c, diag, correct);
  // Of a bushing effect: the class named and acting where it acts.
  out["component_correct"] =
      c.components.empty()
          ? Json(nullptr)
          : Json(correct && out["components"] == Json(c.components));
  out["ambiguous"] = ambiguous;
  out["gap_closed"] = Field(quantification, "gap_closed", nullptr);
  out["leaves_noise"] = Field(quantification, "leaves_noise", false);
  out["correct"] = correct;
  out["confident_wrong"] = !correct && confidence == "high";
  out["named_in_ambiguity"] =
      verdict == "unexplained" && std::find(ambiguous.begin(), ambiguous.end(),
                                            truth_model) != ambiguous.end();
  out["value_in_interval"] = nullptr;
  if (IsHardPoint(c.parameter) && correct) {
    out["value_in_interval"] = PointMoveInRegion(c, quantification);
  } else if (!c.parameter.empty() && correct) {
    for (const Json& p :
         Field(quantification, "effect_parameters", Json::array())) {
      if (p["name"] != "model_parameter." + c.parameter) continue;
      out["value_in_interval"] = p["ci95"][0] <= c.parameter_value &&
                                 c.parameter_value <= p["ci95"][1];
    }
  }
  return out;
}

struct Tally {
  int hits = 0, total = 0;
  Json ToJson(const char* hits_name) const {
    Json out;
    out[hits_name] = hits;
    out["total"] = total;
    out["rate"] = total > 0 ? Json(double(hits) / total) : Json(nullptr);
    return out;
  }
};

bool Flag(const Json& c, const char* name) {
  return c[name].is_boolean() && c[name].get<bool>();
}

Json Figures(const std::vector<Json>& cases) {
  Tally large, clean, parameters, in_interval, closed, placed, stiffness;
  int ambiguous = 0, confident_wrong = 0;
  for (const Json& c : cases) {
    if (c["stiffness_coverage"].is_object()) {
      stiffness.hits += c["stiffness_coverage"]["inside"].get<int>();
      stiffness.total += c["stiffness_coverage"]["total"].get<int>();
    }
    const bool correct = Flag(c, "correct");
    const bool parameter = c["truth"] == "model_parameter";
    const bool beyond = c["size_sigma"].get<double>() > kLargeEffect;
    confident_wrong += Flag(c, "confident_wrong");
    if (c["truth"] == "none") {
      ++clean.total;
      clean.hits += c["verdict"] == "none";
      continue;
    }
    if (correct) {
      // Explained: 80 % of the gap closed, or only noise left (a hold-out
      // that shows the gap weakly measures the fraction no better).
      ++closed.total;
      closed.hits += (c["gap_closed"].is_number() &&
                      c["gap_closed"].get<double>() >= 0.8) ||
                     c.value("leaves_noise", false);
    }
    if (!beyond) continue;
    Tally& tally = parameter ? parameters : large;
    ++tally.total;
    tally.hits += correct;
    if (c["component_correct"].is_boolean()) {
      ++placed.total;
      placed.hits += Flag(c, "component_correct");
    }
    if (!parameter) continue;
    ambiguous += Flag(c, "named_in_ambiguity");
    if (c["value_in_interval"].is_boolean()) {
      ++in_interval.total;
      in_interval.hits += Flag(c, "value_in_interval");
    }
  }
  Json out;
  out["library_effects_beyond_3_sigma"] = large.ToJson("correct");
  out["bushing_effects_beyond_3_sigma_right_component"] =
      placed.ToJson("correct");
  out["clean"] = clean.ToJson("none");
  out["false_alarm_rate"] = clean.total > 0
                                ? Json(1.0 - double(clean.hits) / clean.total)
                                : Json(nullptr);
  out["wrong_parameters_beyond_3_sigma"] = parameters.ToJson("named");
  out["wrong_parameters_beyond_3_sigma"]["one_of_an_ambiguous_pair"] =
      ambiguous;
  out["true_value_in_95_interval"] = in_interval.ToJson("inside");
  out["gap_closed_80_percent_when_correct"] = closed.ToJson("closed");
  out["confident_wrong"] = confident_wrong;
  out["stiffness_in_95_interval_when_correct"] = stiffness.ToJson("inside");
  return out;
}

// The diagnosis competitions' figures (DX: detection, false alarms,
// isolation accuracy, localisation F1) over the effects beyond 3x the
// noise, and how far "high" confidence can be acted on.
Json DxMetrics(const std::vector<Json>& cases) {
  Tally detected, isolated, high_when_correct, high_right;
  int true_positive = 0, false_positive = 0, false_negative = 0;
  for (const Json& c : cases) {
    const bool high = c["confidence"] == "high";
    if (high) {
      ++high_right.total;
      high_right.hits += Flag(c, "correct");
    }
    if (c["truth"] == "none" || c["size_sigma"].get<double>() <= kLargeEffect) {
      continue;
    }
    ++detected.total;
    detected.hits += c["verdict"] != "none";
    ++isolated.total;
    const bool correct = Flag(c, "correct");
    isolated.hits += correct && !(c["component_correct"].is_boolean() &&
                                  !c["component_correct"].get<bool>());
    if (correct) {
      ++high_when_correct.total;
      high_when_correct.hits += high;
    }
    const Json& truth = c["truth_components"];
    if (truth.empty()) continue;
    for (const Json& placed : c["components"]) {
      const bool hit =
          std::find(truth.begin(), truth.end(), placed) != truth.end();
      true_positive += hit;
      false_positive += !hit;
    }
    for (const Json& acting : truth) {
      const Json& placed = c["components"];
      false_negative +=
          std::find(placed.begin(), placed.end(), acting) == placed.end();
    }
  }
  const int f1_denominator =
      2 * true_positive + false_positive + false_negative;
  Json out;
  out["detection"] = detected.ToJson("detected");
  out["isolation_accuracy"] = isolated.ToJson("isolated");
  out["localisation_f1"] = f1_denominator > 0
                               ? Json(2.0 * true_positive / f1_denominator)
                               : Json(nullptr);
  out["high_confidence_when_correct"] = high_when_correct.ToJson("high");
  out["high_confidence_right"] = high_right.ToJson("right");
  return out;
}

Json Confusion(const std::vector<Json>& cases) {
  Json out = Json::object();
  for (const std::string& truth : BlindCaseClasses()) {
    for (const Json& c : cases) {
      if (c["truth"] != truth) continue;
      const std::string column = c["column"];
      if (!out.contains(truth)) out[truth] = Json::object();
      out[truth][column] = out[truth].value(column, 0) + 1;
    }
  }
  return out;
}

// Of the bushing effects: where they act (rows) against where the
// diagnosis placed them (columns).
Json ComponentConfusion(const std::vector<Json>& cases) {
  Json out = Json::object();
  for (const Json& c : cases) {
    if (c["truth_components"].empty()) continue;
    const std::string truth = ComponentLabel(c["truth_components"]);
    const std::string column = ComponentLabel(c["components"]);
    if (!out.contains(truth)) out[truth] = Json::object();
    out[truth][column] = out[truth].value(column, 0) + 1;
  }
  return out;
}

// Per effect class: the detection rate in each size bin and the smallest
// size detected.
Json Power(const std::vector<Json>& cases) {
  Json out = Json::object();
  constexpr int kBins = sizeof(kSizeBins) / sizeof(kSizeBins[0]);
  for (const std::string& truth : BlindCaseClasses()) {
    if (truth == "none") continue;
    Json bins = Json::array();
    double smallest = std::numeric_limits<double>::infinity();
    int any = 0;
    for (int b = 0; b < kBins; ++b) {
      const double from = kSizeBins[b];
      const double to = b + 1 < kBins ? kSizeBins[b + 1]
                                      : std::numeric_limits<double>::infinity();
      int n = 0, detected = 0;
      for (const Json& c : cases) {
        const double size = c["size_sigma"];
        if (c["truth"] != truth || size < from || size >= to) continue;
        ++n;
        detected += Flag(c, "correct");
        if (Flag(c, "correct")) smallest = std::min(smallest, size);
      }
      any += n;
      bins.push_back({{"from_sigma", from},
                      {"to_sigma", std::isinf(to) ? Json(nullptr) : Json(to)},
                      {"cases", n},
                      {"detected", detected}});
    }
    if (any == 0) continue;
    out[truth] = {{"bins", bins},
                  {"smallest_detected_sigma",
                   std::isinf(smallest) ? Json(nullptr) : Json(smallest)}};
  }
  return out;
}

}  // namespace

Status NominalFitSigmaHat(const KcrigConfig& config,
                          const std::vector<Experiment>& experiments,
                          double* sigma_hat) {
  EffectModel nominal;
  Status status = EffectModel::Create(config.model, {}, 0.1, 10, &nominal);
  if (!status.ok()) return status;
  EffectFit fit;
  status = FitEffectModel(nominal, experiments, {}, EffectFitOptions(),
                          config.experiment.step, &fit);
  if (!status.ok()) return status;
  *sigma_hat = fit.result.sigma_hat;
  return Status::Ok();
}

Status LoadValidationRig(const KcrigConfig& config,
                         const std::string& plan_file,
                         ValidationOptions* options) {
  KCRIG_RETURN_IF_ERROR(
      LoadPlantConfig(config.directory, config.model, &options->plant));
  options->plant.step = options->plant_step;
  KCRIG_RETURN_IF_ERROR(LoadRigConfig(config.directory, &options->rig));
  SafetyLimits& safety = options->rig.safety;
  safety.error_position_max = std::numeric_limits<double>::infinity();
  safety.error_angle_max = std::numeric_limits<double>::infinity();
  if (plan_file.empty()) return Status::Ok();
  KCRIG_RETURN_IF_ERROR(CheckRampsOnRig(
      config, options->rig, options->plan.training, plan_file + ": training"));
  return CheckRampsOnRig(config, options->rig, options->plan.holdout,
                         plan_file + ": holdout");
}

Status CheckBlindCaseOnRig(const KcrigConfig& config,
                           const ValidationOptions& options,
                           const BlindCase& c) {
  const std::string what = "case " + std::to_string(c.index) + ": ";
  KCRIG_RETURN_IF_ERROR(
      CheckRampsOnRig(config, options.rig, c.training, what + "training"));
  return CheckRampsOnRig(config, options.rig, c.holdout, what + "holdout");
}

Status RunValidationCase(const KcrigConfig& config,
                         const ValidationOptions& options, int index,
                         std::string* outcome) {
  BlindCase c;
  Status status = DrawBlindCase(index, options.seed, config.model,
                                options.classes, options.plan, &c);
  if (!status.ok()) return status;
  std::vector<Experiment> logs;
  status =
      RecordLogs(config, options, c, /*noise=*/true,
                 static_cast<int>(c.training.size() + c.holdout.size()), &logs);
  if (!status.ok()) return status;
  const auto first_holdout = logs.begin() + c.training.size();
  const std::vector<Experiment> training(
      std::make_move_iterator(logs.begin()),
      std::make_move_iterator(first_holdout));
  const std::vector<Experiment> holdout(std::make_move_iterator(first_holdout),
                                        std::make_move_iterator(logs.end()));
  DiagnosisResult result;
  status = Diagnose(config.model, training, holdout, options.diagnosis,
                    config.experiment.step, &result);
  if (!status.ok()) return status;
  const Json diag = Json::parse(DiagnosisToJson(result, {}, {}, ""));
  // Only now is the truth looked at.
  double size = 0;
  status = EffectSize(config, options, c, &size);
  if (!status.ok()) return status;
  *outcome = Score(c, size, diag).dump();
  return Status::Ok();
}

std::string ValidationToJson(const KcrigConfig& config,
                             const ValidationOptions& options,
                             const std::vector<std::string>& outcomes) {
  std::vector<Json> cases;
  for (const std::string& text : outcomes) cases.push_back(Json::parse(text));
  Json doc;
  doc["config"] = config.directory;
  doc["seed"] = options.seed;
  doc["cases"] = options.cases;
  doc["classes"] =
      options.classes.empty() ? BlindCaseClasses() : options.classes;
  doc["plant_step"] = {{"value", options.plant_step}, {"unit", "s"}};
  doc["plan"] = options.plan.training.empty()
                    ? Json("drawn per case: two training logs, one hold-out")
                    : Json({{"training", Designs(options.plan.training)},
                            {"holdout", Designs(options.plan.holdout)}});
  doc["figures"] = Figures(cases);
  doc["figures"]["dx"] = DxMetrics(cases);
  doc["confusion_rows"] = BlindCaseClasses();
  doc["confusion_columns"] = ConfusionColumns();
  doc["confusion"] = Confusion(cases);
  doc["component_confusion"] = ComponentConfusion(cases);
  doc["power"] = Power(cases);
  doc["case_results"] = cases;
  return doc.dump(2) + "\n";
}

const std::vector<std::string>& ConfusionColumns() {
  static const std::vector<std::string> columns = {
      "none",          "bushing_damping",
      "hysteresis",    "progressive_stiffness",
      "actuator_lag",  "rig_compliance",
      "sensor_offset", "model_parameter",
      "pair",          "unexplained"};
  return columns;
}

std::string ValidationSummary(const std::string& validation_json) {
  const Json doc = Json::parse(validation_json);
  std::string out = "confusion matrix (rows: truth, columns: verdict)\n";
  char line[320];
  std::snprintf(line, sizeof(line), "%22s", "");
  out += line;
  for (const std::string& column : ConfusionColumns()) {
    std::snprintf(line, sizeof(line), " %6.6s", column.c_str());
    out += line;
  }
  out += "\n";
  for (const auto& [truth, row] : doc["confusion"].items()) {
    std::snprintf(line, sizeof(line), "%22s", truth.c_str());
    out += line;
    for (const std::string& column : ConfusionColumns()) {
      std::snprintf(line, sizeof(line), " %6d", row.value(column, 0));
      out += line;
    }
    out += "\n";
  }
  if (!doc["component_confusion"].empty()) {
    out += "bushing effects: where they act -> where kcrig placed them\n";
  }
  for (const auto& [truth, row] : doc["component_confusion"].items()) {
    std::snprintf(line, sizeof(line), "%22s ->", truth.c_str());
    out += line;
    for (const auto& [placed, count] : row.items()) {
      out += " " + placed + " " + count.dump() + ";";
    }
    out.back() = '\n';
  }
  out += "detection rate by effect size (noise units; detected/cases)\n";
  for (const auto& [truth, power] : doc["power"].items()) {
    std::snprintf(line, sizeof(line), "%22s", truth.c_str());
    out += line;
    for (const Json& bin : power["bins"]) {
      if (bin["cases"] == 0) continue;
      const std::string to =
          bin["to_sigma"].is_null() ? "" : bin["to_sigma"].dump();
      std::snprintf(line, sizeof(line), "  [%s,%s) %d/%d",
                    bin["from_sigma"].dump().c_str(), to.c_str(),
                    bin["detected"].get<int>(), bin["cases"].get<int>());
      out += line;
    }
    out += "\n";
  }
  const Json& f = doc["figures"];
  auto tally = [](const Json& t, const char* hits) {
    return std::to_string(t[hits].get<int>()) + "/" +
           std::to_string(t["total"].get<int>());
  };
  out +=
      "library effects > 3x noise correct: " +
      tally(f["library_effects_beyond_3_sigma"], "correct") +
      " (bushing effects in the right component: " +
      tally(f["bushing_effects_beyond_3_sigma_right_component"], "correct") +
      "); clean called none: " + tally(f["clean"], "none") +
      "; wrong parameters > 3x noise named: " +
      tally(f["wrong_parameters_beyond_3_sigma"], "named") + " (+" +
      f["wrong_parameters_beyond_3_sigma"]["one_of_an_ambiguous_pair"].dump() +
      " one of an ambiguous pair), true value in the 95 % interval " +
      tally(f["true_value_in_95_interval"], "inside") +
      "; correct with >= 80 % of the gap closed or only noise left: " +
      tally(f["gap_closed_80_percent_when_correct"], "closed") +
      "; confident wrong answers: " + f["confident_wrong"].dump() +
      "\nstiffness 95 % intervals covering the rig's true value (correct "
      "verdicts; a coverage study): " +
      tally(f["stiffness_in_95_interval_when_correct"], "inside") + "\n";
  if (!f.contains("dx")) return out;
  const Json& dx = f["dx"];
  char f1[32] = "n/a";
  if (dx["localisation_f1"].is_number()) {
    std::snprintf(f1, sizeof(f1), "%.2f", dx["localisation_f1"].get<double>());
  }
  out += "DX metrics (effects > 3x noise): detection " +
         tally(dx["detection"], "detected") + ", false alarms " +
         std::to_string(f["clean"]["total"].get<int>() -
                        f["clean"]["none"].get<int>()) +
         "/" + f["clean"]["total"].dump() + ", isolation accuracy " +
         tally(dx["isolation_accuracy"], "isolated") + ", localisation F1 " +
         f1 + "; high confidence on " +
         tally(dx["high_confidence_when_correct"], "high") +
         " correct verdicts, right when high (any size) " +
         tally(dx["high_confidence_right"], "right") + "\n";
  return out;
}

}  // namespace kcrig
