#include "campaign/campaign.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>

#include "Eigen/QR"
#include "base/atomic_files.h"
#include "base/json_reader.h"
#include "designer/design_step.h"
#include "designer/discrimination.h"
#include "diagnosis/diagnosis_io.h"
#include "estimator/estimate_io.h"
#include "estimator/experiment.h"
#include "nlohmann/json.hpp"
#include "records/run_log.h"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

// Whether the first `count` parameters (the stiffnesses; an adopted
// effect's follow them) are within the target half-width.
bool WithinTarget(const EstimationResult& estimate, size_t count,
                  double target) {
  if (!(target > 0)) return false;
  for (size_t i = 0; i < count && i < estimate.parameters.size(); ++i) {
    const ParameterEstimate& p = estimate.parameters[i];
    if (!p.identifiable) return false;
    const double half = 0.5 * (p.ci95_high - p.ci95_low);
    if (!(half <= target * std::abs(p.value))) return false;
  }
  return true;
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
  // The model checks (campaign.json files written before them have none).
  it->model = node.value("model", "nominal");
  const nlohmann::json model_step =
      node.value("model_step_s", nlohmann::json());
  it->model_step = model_step.is_number() ? model_step.get<double>() : 0.0;
  it->failed_checks = node.value("check", "ok");
  const nlohmann::json adequacy = node.value("adequacy", nlohmann::json());
  it->estimate.adequacy.adequate =
      !adequacy.is_object() || adequacy.value("verdict", "") == "adequate";
  if (adequacy.is_object() && adequacy.contains("reason") &&
      adequacy["reason"].is_string()) {
    it->estimate.adequacy.reason = adequacy["reason"].get<std::string>();
  }
  const nlohmann::json prediction = node.value("prediction", nlohmann::json());
  it->prediction.assessed = prediction.is_object();
  it->prediction.adequate =
      it->prediction.assessed && prediction.value("verdict", "") == "adequate";
  const nlohmann::json consistency =
      node.value("consistency", nlohmann::json());
  it->consistent =
      !consistency.is_object() || consistency.value("consistent", true);
  const nlohmann::json diagnosis = node.value("diagnosis", nlohmann::json());
  if (diagnosis.is_object()) {
    it->diagnosed = true;
    it->diagnosis.verdict = diagnosis.value("verdict", "");
    it->diagnosis.model = diagnosis.value("model", it->diagnosis.verdict);
    it->diagnosis.components =
        diagnosis.value("components", std::vector<std::string>());
    it->action = diagnosis.value("action", "");
    it->rejected_adoption = diagnosis.value("rejected_adoption", "");
  }
  // The stiffnesses, then an adopted effect's parameters (as `estimate`
  // holds them).
  for (size_t i = 0; i < parameters.size(); ++i) {
    KCRIG_RETURN_IF_ERROR(ReadParameterEstimate(
        parameters[i], where + ".parameters[" + std::to_string(i) + "]",
        &it->estimate.parameters.emplace_back()));
  }
  auto read_list = [&](const char* key, EstimationResult* estimate) {
    const nlohmann::json list = node.value(key, nlohmann::json::array());
    if (!list.is_array()) {
      return Status::Error(where + "." + key + ": not a list");
    }
    for (size_t i = 0; i < list.size(); ++i) {
      KCRIG_RETURN_IF_ERROR(ReadParameterEstimate(
          list[i], where + "." + key + "[" + std::to_string(i) + "]",
          &estimate->parameters.emplace_back()));
    }
    return Status::Ok();
  };
  KCRIG_RETURN_IF_ERROR(read_list("effect_parameters", &it->estimate));
  return read_list("nominal_parameters", &it->nominal_estimate);
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
  KCRIG_RETURN_IF_ERROR(
      ResolveParameters(config.model, options.estimator.parameters, &indices));
  if (!options.close_loop) return Status::Ok();
  // An adopted effect model holds the five bushings first, in this order.
  EffectModel nominal;
  KCRIG_RETURN_IF_ERROR(
      EffectModel::Create(config.model, {}, 0.1, 10, &nominal));
  std::vector<std::string> bushings;
  for (const EffectParameter& p : nominal.parameters())
    bushings.push_back(p.name);
  if (options.estimator.parameters != bushings) {
    return Status::Error(
        "the campaign closes the loop with the diagnosis, whose model "
        "estimates the five bushing stiffnesses: the estimated parameters "
        "must be c_O1, c_O2, c_V1, c_V2, c_P");
  }
  return Status::Ok();
}

namespace {

// An adopted model is fitted down to an eighth of the configured step: a
// Dahl element with a large loop (F / sigma of tens of um) errs by 0.3-0.4
// sigma at a quarter, enough for Ljung-Box to see where it reverses.
constexpr int kMaxStepHalvings = 3;

}  // namespace

Eigen::MatrixXd StiffnessInformation(const Eigen::MatrixXd& information,
                                     int n) {
  const int m = static_cast<int>(information.rows()) - n;
  if (m <= 0) return information;
  const Eigen::MatrixXd ee = information.bottomRightCorner(m, m);
  const Eigen::MatrixXd ce = information.topRightCorner(n, m);
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(ee);
  return information.topLeftCorner(n, n) - ce * cod.solve(ce.transpose());
}

namespace {

// One campaign over one state, an iteration in named stages: run the
// experiment, predict it, fit, check, diagnose and act, design the next.
class CampaignRun {
 public:
  CampaignRun(const KcrigConfig& config, const CampaignOptions& options,
              const RigRunner& rig, const std::string& out_dir,
              std::vector<CampaignIteration>* iterations)
      : config_(config),
        options_(options),
        rig_(rig),
        out_dir_(out_dir),
        iterations_(iterations),
        progress_(options.callback),
        bounds_{config.experiment.phi_bounds, config.experiment.z_a_bounds},
        next_{config.experiment.phi, config.experiment.z_a} {}

  Status Run() {
    iterations_->clear();
    KCRIG_RETURN_IF_ERROR(ValidateCampaignOptions(config_, options_));
    KCRIG_RETURN_IF_ERROR(ResolveParameters(
        config_.model, options_.estimator.parameters, &indices_));
    estimator_ = options_.estimator;
    estimator_.callback = progress_.Nested();
    current_ = ParameterValues(config_.model, indices_);
    for (int k = 0; k <= options_.iterations; ++k) {
      CampaignIteration it;
      it.index = k;
      KCRIG_RETURN_IF_ERROR(RunExperiment(&it));
      if (k > 0) KCRIG_RETURN_IF_ERROR(Predict(&it));
      KCRIG_RETURN_IF_ERROR(Fit(&it));
      if (k > 0 && iterations_->back().model == it.model) {
        CheckConsistency(iterations_->back().estimate, &it);
      }
      it.failed_checks = CampaignCheck(it);
      if (it.failed_checks != "ok" && options_.close_loop) {
        KCRIG_RETURN_IF_ERROR(DiagnoseAndAct(&it));
      }
      KCRIG_RETURN_IF_ERROR(WriteEstimate(it));
      it.criterion_of_data =
          EvaluateCriterion(options_.criterion, DesignPrior(it)).value;
      const bool done = k == options_.iterations || it.action == "stopped" ||
                        WithinTarget(it.estimate, indices_.size(),
                                     options_.target_relative_halfwidth);
      if (!done && it.action != "discriminate") {
        KCRIG_RETURN_IF_ERROR(DesignNext(&it));
      }
      if (options_.isolability) KCRIG_RETURN_IF_ERROR(Isolate(done, &it));
      if (options_.on_iteration) options_.on_iteration(it);
      iterations_->push_back(std::move(it));
      if (done) break;
    }
    return Status::Ok();
  }

 private:
  Status Stage(const std::string& text) {
    return progress_.Report({text}) ? Status::Ok() : Interrupted("campaign");
  }

  std::string Dir(int k) const { return CampaignIterationDir(out_dir_, k); }

  // Runs the next experiment (the designed one, or a discriminating one)
  // and reads its log; the earlier logs are kept.
  Status RunExperiment(CampaignIteration* it) {
    namespace fs = std::filesystem;
    const int k = it->index;
    it->experiment = next_;
    it->special_excitation = special_next_;
    std::error_code error;
    fs::create_directories(Dir(k), error);
    if (error) {
      return Status::Error(Dir(k) + ": cannot create (" + error.message() +
                           ")");
    }
    // A matrix of an earlier campaign in this folder is not this one's
    // (Isolate writes this one's, when it has one).
    fs::remove(fs::path(Dir(k)) / "isolability.json", error);
    const std::string csv = (fs::path(Dir(k)) / "run.csv").string();
    char text[160];
    std::snprintf(text, sizeof(text),
                  "iteration %d: running the rig at phi %.2f deg, z_a %.3f m",
                  k, next_.phi / kDegree, next_.z_a);
    KCRIG_RETURN_IF_ERROR(Stage(text));
    const RampExcitation<double> excitation =
        special_next_ ? *special_next_
                      : config_.experiment.Excitation(next_.phi, next_.z_a);
    special_next_.reset();
    KCRIG_RETURN_IF_ERROR(rig_(excitation, k, csv));
    logs_.push_back(csv);
    it->logs = logs_;
    return LoadExperiment(csv, config_, "", &experiments_.emplace_back());
  }

  // The new log predicted by the previous estimate before it is fitted.
  Status Predict(CampaignIteration* it) {
    const CampaignIteration& previous = iterations_->back();
    const std::vector<Experiment> newest = {experiments_.back()};
    if (previous.model == "nominal") {
      return PredictExperiments(config_.model, newest, estimator_,
                                previous.estimate, config_.experiment.step,
                                &it->prediction);
    }
    return PredictEffectModel(adopted_, adopted_fit_, newest,
                              config_.experiment.step, estimator_.adequacy,
                              &it->prediction);
  }

  // The nominal fit to all logs and, with an adopted effect, that model's
  // fit (the iteration's estimate) beside it.
  Status Fit(CampaignIteration* it) {
    char text[160];
    std::snprintf(text, sizeof(text), "iteration %d: estimating from %zu log%s",
                  it->index, logs_.size(), logs_.size() == 1 ? "" : "s");
    KCRIG_RETURN_IF_ERROR(Stage(text));
    EstimationResult nominal;
    KCRIG_RETURN_IF_ERROR(Estimate(config_.model, experiments_, estimator_,
                                   current_, config_.experiment.step,
                                   &nominal));
    for (size_t i = 0; i < current_.size(); ++i) {
      current_[i] = nominal.parameters[i].value;
    }
    if (adopted_name_.empty()) {
      it->estimate = std::move(nominal);
      return Status::Ok();
    }
    it->model = adopted_name_;
    it->nominal_estimate = std::move(nominal);
    return FitAdopted(it);
  }

  Status FitAdopted(CampaignIteration* it) {
    EffectFit fit;
    KCRIG_RETURN_IF_ERROR(FitModel(adopted_, adopted_fit_.values,
                                   adopted_fit_.result.integrator_step, &fit));
    adopted_fit_ = std::move(fit);
    it->estimate = adopted_fit_.result;
    it->model_step = adopted_fit_.result.integrator_step;
    return Status::Ok();
  }

  // Fits `model` from `start`, beginning at `from_step` (0: the configured
  // step). An adopted model keeps the finest step it has needed: its
  // estimates from one iteration to the next are then nested.
  Status FitModel(const EffectModel& model, const std::vector<double>& start,
                  double from_step, EffectFit* fit) {
    const double step = config_.experiment.step;
    int halvings = 0;
    while (from_step > 0 && halvings < kMaxStepHalvings &&
           step / (1 << halvings) > 1.5 * from_step) {
      ++halvings;
    }
    EffectFitOptions options;
    options.uncertainty = estimator_;
    options.callback = progress_.Nested();
    // Whether the model with the effect explains the logs is the model's
    // question, not its integrator's: its error is estimated at every step,
    // the finest allowed included.
    options.estimate_discretisation = true;
    options.max_step_halvings = kMaxStepHalvings - halvings;
    return FitEffectModel(model,
                          RefinedExperiments(experiments_, 1 << halvings),
                          start, options, step / (1 << halvings), fit);
  }

  // A check failed: diagnose the logs (the newest as hold-out when there
  // are older ones) and act on the verdict.
  Status DiagnoseAndAct(CampaignIteration* it) {
    char text[160];
    std::snprintf(text, sizeof(text), "iteration %d: diagnosing (%s)",
                  it->index, it->failed_checks.c_str());
    KCRIG_RETURN_IF_ERROR(Stage(text));
    std::vector<Experiment> training = experiments_, holdout;
    if (training.size() > 1) {
      holdout.push_back(training.back());
      training.pop_back();
    }
    DiagnosisOptions options = options_.diagnosis;
    options.estimator.lower_scale = estimator_.lower_scale;
    options.estimator.upper_scale = estimator_.upper_scale;
    options.callback = progress_.Nested();
    it->diagnosed = true;
    KCRIG_RETURN_IF_ERROR(Diagnose(config_.model, training, holdout, options,
                                   config_.experiment.step, &it->diagnosis));
    KCRIG_RETURN_IF_ERROR(WriteDiagnosis(*it, holdout.empty()));
    const DiagnosisResult& d = it->diagnosis;
    if (d.verdict == "none") {
      it->action = "none";
    } else if (d.verdict != "unexplained") {
      return Adopt(d, holdout.empty(), it);
    } else if (!d.ambiguous_a.empty()) {
      return Discriminate(d, it);
    } else if (holdout.empty()) {
      // One log cannot tell most effects from the stiffnesses: design the
      // next experiment and diagnose again with it as hold-out.
      it->action = "undecided";
    } else {
      it->action = "stopped";
    }
    return Status::Ok();
  }

  // The attributed effect joins the model when the model with it explains
  // all logs (refitted to them); else the verdict is as good as unexplained.
  Status Adopt(const DiagnosisResult& d, bool one_log, CampaignIteration* it) {
    EffectModel model;
    KCRIG_RETURN_IF_ERROR(
        EffectModel::CreateNamed(config_.model, d.model, estimator_.lower_scale,
                                 estimator_.upper_scale, &model));
    std::vector<double> start;
    for (const CandidateScore& s : d.ranking) {
      if (s.model == d.model && s.ok) start = s.fit.values;
    }
    EffectFit fit;
    KCRIG_RETURN_IF_ERROR(FitModel(model, start, 0, &fit));
    if (!fit.result.adequacy.adequate) {
      it->action = one_log ? "undecided" : "stopped";
      char step[64];
      std::snprintf(step, sizeof(step), " (fitted at a %.3g ms step)",
                    fit.result.integrator_step * 1e3);
      it->rejected_adoption = fit.result.adequacy.reason + step;
      return Status::Ok();
    }
    if (it->model == "nominal") it->nominal_estimate = it->estimate;
    adopted_ = std::move(model);
    adopted_name_ = d.model;
    adopted_fit_ = std::move(fit);
    it->action = "adopted";
    it->model = adopted_name_;
    it->estimate = adopted_fit_.result;
    it->model_step = adopted_fit_.result.integrator_step;
    return Status::Ok();
  }

  Status Discriminate(const DiagnosisResult& d, CampaignIteration* it) {
    DiscriminatingDesign design;
    DiagnosisOptions options = options_.diagnosis;
    options.estimator.lower_scale = estimator_.lower_scale;
    options.estimator.upper_scale = estimator_.upper_scale;
    KCRIG_RETURN_IF_ERROR(DesignToTellApart(config_, options, d, d.ambiguous_a,
                                            d.ambiguous_b, &design));
    special_next_ = design.excitation;
    next_ = {design.excitation.phi, design.excitation.z_a};
    it->action = "discriminate";
    return Status::Ok();
  }

  Status WriteDiagnosis(const CampaignIteration& it, bool no_holdout) const {
    const std::vector<std::string> training(
        logs_.begin(), no_holdout ? logs_.end() : logs_.end() - 1);
    const std::vector<std::string> holdout(
        no_holdout ? logs_.end() : logs_.end() - 1, logs_.end());
    return WriteFilesAtomically(
        {{(std::filesystem::path(Dir(it.index)) / "diag.json").string(),
          DiagnosisToJson(it.diagnosis, training, holdout, "")}});
  }

  Status WriteEstimate(const CampaignIteration& it) const {
    return WriteFilesAtomically(
        {{(std::filesystem::path(Dir(it.index)) / "est.json").string(),
          EstimationResultToJson(it.estimate, logs_, {}, {})}});
  }

  // The information of the data about the stiffnesses: the estimate's, or
  // with an adopted effect its Schur complement (the effect's parameters
  // are nuisance: the criterion covers the stiffnesses, which the campaign
  // is for).
  Eigen::MatrixXd DesignPrior(const CampaignIteration& it) const {
    return StiffnessInformation(it.estimate.information,
                                static_cast<int>(indices_.size()));
  }

  Status DesignNext(CampaignIteration* it) {
    char text[160];
    std::snprintf(text, sizeof(text), "iteration %d: designing (%s, %s)",
                  it->index, CriterionName(options_.criterion),
                  options_.optimizer.c_str());
    KCRIG_RETURN_IF_ERROR(Stage(text));
    DesignStepOptions step;
    step.names = options_.estimator.parameters;
    // With an adopted effect: at its stiffnesses, the new experiment's
    // information from the nominal model's sensitivities there (the
    // designer has no sensitivities of the effect models).
    step.values = current_;
    if (!adopted_name_.empty()) {
      step.values.assign(adopted_fit_.values.begin(),
                         adopted_fit_.values.begin() + current_.size());
    }
    step.prior_information = DesignPrior(*it);
    step.criterion = options_.criterion;
    step.optimizer = options_.optimizer;
    step.objective = options_.objective;
    const std::string designing = text;
    step.objective.callback = [&](const IterationSummary& batch) {
      return progress_.Report(
                 {designing + " | " + options_.optimizer + ": " + batch.stage,
                  batch.fraction, batch.done, batch.total})
                 ? CallbackReturn::kContinue
                 : CallbackReturn::kAbort;
    };
    step.optimizer_options = options_.optimizer_options;
    const Design start{
        std::clamp(next_.phi, bounds_.phi.lower, bounds_.phi.upper),
        std::clamp(next_.z_a, bounds_.z_a.lower, bounds_.z_a.upper)};
    // An adopted wrong "known" parameter is the model's own: designed with
    // its estimate.
    KcrigConfig design_config = config_;
    if (!adopted_name_.empty()) {
      std::vector<std::string> names;
      for (const ParameterEstimate& p : adopted_fit_.result.parameters) {
        names.push_back(p.name);
      }
      ApplyFreedParameters(names, adopted_fit_.values, &design_config.model);
    }
    KCRIG_RETURN_IF_ERROR(DesignStep(design_config, step, start, &it->design));
    it->designed = true;
    KCRIG_RETURN_IF_ERROR(WriteFilesAtomically(
        {{(std::filesystem::path(Dir(it->index)) / "design.json").string(),
          DesignRunsToJson(options_.criterion, {it->design})}}));
    next_ = it->design.result.best;
    return Status::Ok();
  }

  // The isolability of the logs so far (one analysis, grown a log at a
  // time) and, unless done, the ties left with the next experiment. Only a
  // stop ends the campaign here: a candidate that cannot be evaluated on a
  // log leaves the iteration's isolability not judged, with its reason.
  Status Isolate(bool done, CampaignIteration* it) {
    KCRIG_RETURN_IF_ERROR(Stage("iteration " + std::to_string(it->index) +
                                ": which faults the logs tell apart"));
    Status status = Status::Ok();
    // Grown by the newest log; (re)built from every log when it has none.
    size_t first = experiments_.size() - 1;
    if (!isolability_ready_) {
      IsolabilityOptions options = options_.isolability_options;
      options.callback = progress_.Nested();
      options.num_threads = options_.objective.num_threads;
      status = IsolabilityAnalysis::Create(
          config_.model, config_.experiment.step, options, &isolability_);
      first = 0;
    }
    for (size_t k = first; status.ok() && k < experiments_.size(); ++k) {
      status = isolability_.Add(experiments_[k]);
    }
    isolability_ready_ = status.ok();
    if (status.ok()) {
      it->isolability = isolability_.Matrix();
      status = WriteFilesAtomically(
          {{(std::filesystem::path(Dir(it->index)) / "isolability.json")
                .string(),
            IsolabilityToJson(it->isolability) + "\n"}});
    }
    if (status.ok() && !done) {
      IsolabilityAnalysis with_next = isolability_;
      status = with_next.Add(PlannedExperiment(
          special_next_.value_or(
              config_.experiment.Excitation(next_.phi, next_.z_a)),
          config_.experiment));
      if (status.ok()) {
        it->ties_with_next = static_cast<int>(with_next.Matrix().Ties().size());
      }
    }
    if (progress_.aborted()) return Interrupted("campaign");
    if (!status.ok()) {
      it->isolability = Isolability();
      it->isolability_error = status.message();
    }
    return Status::Ok();
  }

  void CheckConsistency(const EstimationResult& previous,
                        CampaignIteration* it) const {
    for (size_t i = 0; i < it->estimate.parameters.size(); ++i) {
      const ParameterEstimate& now = it->estimate.parameters[i];
      const ParameterEstimate& before = previous.parameters[i];
      // The new fit contains the old data: for nested efficient estimates
      // Var(new - old) = se_old^2 - se_new^2. After a change of model (or
      // when the new interval is not narrower) both count in full.
      const double nested = before.standard_error * before.standard_error -
                            now.standard_error * now.standard_error;
      const double se =
          nested > 0.01 * before.standard_error * before.standard_error
              ? std::sqrt(nested)
              : std::hypot(now.standard_error, before.standard_error);
      if (!std::isfinite(se) || !(se > 0)) continue;
      const double z = std::abs(now.value - before.value) / se;
      if (z > it->consistency_z) {
        it->consistency_z = z;
        it->least_consistent = now.name;
      }
    }
    it->consistent = it->consistency_z <= options_.max_consistency_z;
  }

  const KcrigConfig& config_;
  const CampaignOptions& options_;
  const RigRunner& rig_;
  const std::string out_dir_;
  std::vector<CampaignIteration>* iterations_;
  ProgressReporter progress_;
  const DesignBounds bounds_;
  EstimatorOptions estimator_;
  std::vector<int> indices_;
  std::vector<double> current_;  // the nominal fit's stiffnesses
  std::vector<std::string> logs_;
  std::vector<Experiment> experiments_;  // one per log, in order
  IsolabilityAnalysis isolability_;      // of experiments_
  bool isolability_ready_ = false;
  Design next_;
  std::optional<RampExcitation<double>> special_next_;
  // The adopted effect model ("" none) and its latest fit.
  std::string adopted_name_;
  EffectModel adopted_;
  EffectFit adopted_fit_;
};

}  // namespace

std::string CampaignCheck(const CampaignIteration& it) {
  std::string word;
  if (!it.estimate.adequacy.adequate) word = "inadequate fit";
  // The prediction and the consistency were of the model an adoption
  // replaced.
  if (it.action == "adopted") return word.empty() ? "ok" : word;
  if (it.prediction.assessed && !it.prediction.adequate) {
    word += (word.empty() ? "" : ", ") + std::string("mispredicted");
  }
  if (!it.consistent) {
    word += (word.empty() ? "" : ", ") + std::string("inconsistent");
  }
  return word.empty() ? "ok" : word;
}

Status RunCampaign(const KcrigConfig& config, const CampaignOptions& options,
                   const RigRunner& rig, const std::string& out_dir,
                   std::vector<CampaignIteration>* iterations) {
  return CampaignRun(config, options, rig, out_dir, iterations).Run();
}

namespace {

// The isolability's counts for campaign.json (the matrix is the
// iteration's isolability.json).
nlohmann::ordered_json IsolabilityCounts(const CampaignIteration& it) {
  const Isolability& iso = it.isolability;
  long visible = 0;
  for (bool v : iso.visible) visible += v ? 1 : 0;
  const auto ties = iso.Ties();
  nlohmann::ordered_json pairs = nlohmann::ordered_json::array();
  for (const auto& [i, j] : ties) {
    pairs.push_back({iso.candidates[i], iso.candidates[j]});
  }
  return {{"num_candidates", iso.candidates.size()},
          {"seen", visible},
          {"pairs", visible * (visible - 1) / 2},
          {"ties", pairs},
          {"ties_with_next", it.ties_with_next >= 0
                                 ? nlohmann::ordered_json(it.ties_with_next)
                                 : nlohmann::ordered_json()}};
}

// One iteration's entry of campaign.json.
nlohmann::ordered_json IterationEntry(const CampaignIteration& it) {
  // The stiffnesses (the campaign's parameters) apart from an adopted
  // effect's, so that every iteration lists the same `parameters`.
  const size_t stiffnesses = CampaignParameterCount(it);
  nlohmann::ordered_json entry = {
      {"iteration", it.index},
      {"logs", it.logs},
      {"experiment",
       {{"phi_deg", it.experiment.phi / kDegree}, {"z_a", it.experiment.z_a}}},
      {"model", it.model},
      {"model_step_s", it.model_step > 0 ? nlohmann::ordered_json(it.model_step)
                                         : nlohmann::ordered_json()},
      {"parameters",
       ParameterEstimatesToJson(it.estimate.parameters, 0, stiffnesses)},
      {"effect_parameters",
       ParameterEstimatesToJson(it.estimate.parameters, stiffnesses)},
      {"nominal_parameters",
       ParameterEstimatesToJson(it.nominal_estimate.parameters)},
      {"check", it.failed_checks},
      {"adequacy",
       nlohmann::ordered_json::parse(AdequacyToJson(it.estimate.adequacy))},
      {"prediction", it.prediction.assessed ? nlohmann::ordered_json::parse(
                                                  AdequacyToJson(it.prediction))
                                            : nlohmann::ordered_json()},
      {"consistency",
       {{"max_z", it.consistency_z},
        {"parameter", it.least_consistent},
        {"consistent", it.consistent}}},
      {"diagnosis",
       it.diagnosed
           ? nlohmann::ordered_json{{"verdict", it.diagnosis.verdict},
                                    {"model", it.diagnosis.model},
                                    {"components", it.diagnosis.components},
                                    {"confidence", it.diagnosis.confidence},
                                    {"reason", it.diagnosis.reason},
                                    {"gap_source", it.diagnosis.gap_source},
                                    {"action", it.action},
                                    {"rejected_adoption", it.rejected_adoption}}
           : nlohmann::ordered_json()},
      {"criterion_of_data", it.criterion_of_data}};
  if (!it.isolability.candidates.empty()) {
    entry["isolability"] = IsolabilityCounts(it);
  } else if (!it.isolability_error.empty()) {
    entry["isolability"] = {{"error", it.isolability_error}};
  }
  if (it.special_excitation) {
    const RampExcitation<double>& e = *it.special_excitation;
    entry["experiment"]["excitation"] = {{"fmax_n", e.fmax},
                                         {"tf_s", e.duration},
                                         {"hold_s", e.hold},
                                         {"return_s", e.return_duration}};
  }
  if (it.designed) {
    const OptimizationResult& r = it.design.result;
    entry["next_design"] = {{"optimizer", r.optimizer},
                            {"phi_deg", r.best.phi / kDegree},
                            {"z_a", r.best.z_a},
                            {"criterion_at_start", r.start_value},
                            {"criterion_at_optimum", r.best_value},
                            {"evaluations", r.evaluations}};
  }
  return entry;
}

}  // namespace

std::string CampaignIterationToJson(const CampaignIteration& it) {
  return IterationEntry(it).dump(
      -1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

std::string CampaignToJson(Criterion criterion,
                           const std::vector<CampaignIteration>& iterations) {
  nlohmann::ordered_json doc;
  doc["format"] = "kcrig campaign 1";
  doc["criterion"] = CriterionName(criterion);
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const CampaignIteration& it : iterations) {
    list.push_back(IterationEntry(it));
  }
  doc["iterations"] = list;
  return doc.dump(2) + "\n";
}

std::string CampaignIterationDir(const std::string& out_dir, int index) {
  return (std::filesystem::path(out_dir) /
          ("iteration_" + std::to_string(index)))
      .string();
}

size_t CampaignParameterCount(const CampaignIteration& it) {
  const size_t all = it.estimate.parameters.size();
  const size_t nominal = it.nominal_estimate.parameters.size();
  // A file without the nominal model's parameters has no effect's either.
  return it.model == "nominal" || nominal == 0 ? all : std::min(nominal, all);
}

Status ReadCampaign(const std::string& out_dir, Criterion* criterion,
                    std::vector<CampaignIteration>* iterations) {
  const std::string file =
      (std::filesystem::path(out_dir) / "campaign.json").string();
  return GuardedRead(
      file, [&] { return ReadCampaignJson(out_dir, criterion, iterations); });
}

namespace {

// "faults the logs tell apart: 1033 of 1081 pairs (48 ties: a ~ b, c ~ d,
// e ~ f, ...); with the next experiment 50 ties", or why it was not judged.
std::string IsolabilityLine(const CampaignIteration& it) {
  if (!it.isolability_error.empty()) {
    return "  faults the logs tell apart: not judged (" + it.isolability_error +
           ")\n";
  }
  const Isolability& iso = it.isolability;
  if (iso.candidates.empty()) return "";
  const auto ties = iso.Ties();
  long visible = 0;
  for (bool v : iso.visible) visible += v ? 1 : 0;
  const long pairs = visible * (visible - 1) / 2;
  char line[200];
  std::snprintf(line, sizeof(line),
                "  faults the logs tell apart: %ld of %ld pairs (%zu ties",
                pairs - static_cast<long>(ties.size()), pairs, ties.size());
  std::string out = line;
  // The first few by name; the rest are in isolability.json.
  constexpr size_t kShown = 3;
  for (size_t k = 0; k < std::min(kShown, ties.size()); ++k) {
    out += (k == 0 ? ": " : ", ") + iso.candidates[ties[k].first] + " ~ " +
           iso.candidates[ties[k].second];
  }
  if (ties.size() > kShown) out += ", ...";
  out += ")";
  const long unseen = static_cast<long>(iso.candidates.size()) - visible;
  if (unseen > 0) out += "; " + std::to_string(unseen) + " not seen";
  if (it.ties_with_next >= 0) {
    out += "; with the next experiment " + std::to_string(it.ties_with_next) +
           (it.ties_with_next == 1 ? " tie" : " ties");
  }
  return out + "\n";
}

// What the diagnosis said and what the campaign did about it.
std::string DiagnosisAction(const CampaignIteration& it) {
  const DiagnosisResult& d = it.diagnosis;
  std::string out = "  checks failed (" + it.failed_checks +
                    "): diagnosis verdict " + d.verdict +
                    (d.confidence.empty() ? "" : " (" + d.confidence + ")") +
                    ": " + d.reason + "\n";
  if (it.action == "adopted") {
    out += "  -> adopted: the model is now nominal + " + it.model +
           ", refitted to all logs:\n" +
           EstimationSummary(it.estimate, it.logs, {}, {});
  } else if (it.action == "discriminate") {
    out += "  -> " + d.ambiguous_a + " and " + d.ambiguous_b +
           " explain the logs alike: the next experiment is the one that "
           "tells them apart\n";
  } else if (!it.rejected_adoption.empty()) {
    out += "  -> not adopted: the model with " + d.verdict +
           " does not explain the logs either (" + it.rejected_adoption + ")" +
           (it.action == "stopped"
                ? "; the campaign stops designing (the intervals above are "
                  "not to be trusted)\n"
                : "; the next experiment is designed as usual and the "
                  "diagnosis repeated with it as hold-out\n");
  } else if (it.action == "undecided") {
    out +=
        "  -> one log cannot tell the effect from the stiffnesses: the "
        "next experiment is designed as usual and the diagnosis repeated "
        "with it as hold-out\n";
  } else if (it.action == "stopped") {
    out +=
        "  -> no effect of the library explains the gap: the campaign "
        "stops designing (the intervals above are not to be trusted)\n";
  } else {
    out +=
        "  -> the diagnosis finds no gap beyond the noise: the campaign "
        "goes on with the " +
        it.model + " model\n";
  }
  return out;
}

}  // namespace

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
  if (it.model != "nominal" && it.action != "adopted") {
    out += "  model: nominal + " + it.model + " (adopted earlier)\n";
  }
  if (it.prediction.assessed) {
    out +=
        "  prediction of this experiment by the previous estimate, before "
        "its fit: " +
        AdequacyLine(it.prediction) + "\n";
  }
  // The fit the checks judged: the nominal one when an effect was adopted
  // here (the adopted fit follows with the diagnosis).
  out += EstimationSummary(
      it.action == "adopted" ? it.nominal_estimate : it.estimate, it.logs, {},
      {});
  if (!it.least_consistent.empty()) {
    std::snprintf(line, sizeof(line),
                  "  consistency with the previous estimate: largest change "
                  "%.1f combined standard errors (%s)%s\n",
                  it.consistency_z, it.least_consistent.c_str(),
                  it.consistent ? "" : ": the earlier intervals did not hold");
    out += line;
  }
  if (it.diagnosed) out += DiagnosisAction(it);
  out += IsolabilityLine(it);
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
