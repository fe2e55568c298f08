#include "report/report.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "base/atomic_files.h"
#include "base/json_reader.h"
#include "base/json_writer.h"
#include "campaign/campaign.h"
#include "designer/criteria.h"
#include "designer/criterion_surface.h"
#include "designer/kriging.h"
#include "diagnosis/diagnosis_io.h"
#include "estimator/effect_model.h"
#include "estimator/estimate_io.h"
#include "estimator/estimator.h"
#include "estimator/experiment.h"
#include "kc_sheet/kc_sheet.h"
#include "kc_sheet/kc_sheet_io.h"
#include "nlohmann/json.hpp"
#include "records/run_log.h"
#include "records/timing_file.h"
#include "report/report_page.h"
#include "rt_core/model/channels.h"
#include "rt_core/model/plant_effects.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// Every `stride`-th index so that at most `max_points` remain (the last
// sample always).
std::vector<size_t> Decimation(size_t count, int max_points) {
  std::vector<size_t> index;
  const size_t stride =
      std::max<size_t>(1, (count + max_points - 1) / std::max(1, max_points));
  for (size_t j = 0; j < count; j += stride) index.push_back(j);
  if (!index.empty() && index.back() != count - 1) index.push_back(count - 1);
  return index;
}

// Measured, model and residual per channel of one experiment, decimated.
Json TimeHistories(const Experiment& e, const std::vector<Vec6<double>>& model,
                   int max_points) {
  const size_t n = e.measured.size();
  const std::vector<size_t> index = Decimation(n, max_points);
  Json t = Json::array();
  for (size_t j : index) t.push_back(j * e.sample_period);
  Json channels = Json::array();
  for (int k = 0; k < 6; ++k) {
    Json measured = Json::array(), predicted = Json::array(),
         residual = Json::array();
    double sum = 0;
    int count = 0;
    for (size_t j = 0; j < n; ++j) {
      if (!Observed(e, j)) continue;
      const double r = e.measured[j](k) - model[j](k);
      sum += r * r;
      ++count;
    }
    for (size_t j : index) {
      predicted.push_back(ChannelDisplayValue(k, model[j](k)));
      // A cycle without a fresh sample measured nothing: a gap in the plot.
      if (!Observed(e, j)) {
        measured.push_back(nullptr);
        residual.push_back(nullptr);
        continue;
      }
      measured.push_back(ChannelDisplayValue(k, e.measured[j](k)));
      residual.push_back(
          ChannelDisplayValue(k, e.measured[j](k) - model[j](k)));
    }
    channels.push_back(
        {{"name", kChannelNames[k]},
         {"unit", ChannelDisplayUnit(k)},
         {"measured", measured},
         {"model", predicted},
         {"residual", residual},
         {"rms",
          ChannelDisplayValue(k, count > 0 ? std::sqrt(sum / count) : 0.0)},
         {"sigma", ChannelDisplayValue(k, e.sigma(k))}});
  }
  return {{"t", t}, {"channels", channels}};
}

// The estimate of iteration `index` (its est.json: every parameter the fit
// had, an adopted effect's included, and the step it was fitted at).
Status ReadIterationEstimate(const fs::path& root, int index,
                             EstimateFile* estimate) {
  return ReadEstimateFile(
      (fs::path(CampaignIterationDir(root.string(), index)) / "est.json")
          .string(),
      estimate);
}

// What the model of `it` predicts for `e`: the nominal model or the one
// with its adopted effect, at its estimate (parameters it did not estimate
// at their configured values) and the step it was fitted at.
Status Predict(const KcrigConfig& config, const fs::path& root,
               const CampaignIteration& it, const Experiment& e,
               std::vector<Vec6<double>>* sensed) {
  EstimateFile estimate;
  KCRIG_RETURN_IF_ERROR(ReadIterationEstimate(root, it.index, &estimate));
  SuspensionParameters<double> base = config.model;
  for (size_t k = 0; k < estimate.names.size(); ++k) {
    if (double* p = FindParameter(&base, estimate.names[k])) {
      *p = estimate.values[k];
    }
  }
  EffectModel model;
  // The estimator's default stiffness bounds, as the diagnosis uses them.
  const EstimatorOptions bounds;
  KCRIG_RETURN_IF_ERROR(EffectModel::CreateNamed(
      base, it.model, bounds.lower_scale, bounds.upper_scale, &model));
  std::vector<double> values;
  for (const EffectParameter& p : model.parameters()) {
    values.push_back(p.initial);
    for (size_t k = 0; k < estimate.names.size(); ++k) {
      if (estimate.names[k] == p.FullName()) values.back() = estimate.values[k];
    }
  }
  // The log's samples at the step of the fit (a power-of-two fraction of
  // the configured one).
  const double step = estimate.integrator_step > 0 ? estimate.integrator_step
                                                   : config.experiment.step;
  const int refine =
      std::max(1, static_cast<int>(std::lround(config.experiment.step / step)));
  return SimulateEffectModel(model, values, RefinedExperiments({e}, refine)[0],
                             config.experiment.step / refine, sensed);
}

// A parameter's unit as engineers read it and the factor from SI to it.
std::pair<std::string, double> PageUnit(const std::string& si) {
  if (si == "N/m") return {"N/mm", 1e-3};
  if (si == "N s/m") return {"N s/mm", 1e-3};
  if (si == "m") return {"mm", 1e3};
  return {si, 1.0};
}

// The folder name of a campaign iteration, e.g. "iteration_1".
std::string IterationName(const fs::path& root, int index) {
  return fs::path(CampaignIterationDir(root.string(), index))
      .filename()
      .string();
}

// An interval's bound as the page shows it: null where the estimate gives
// none (a parameter the logs do not determine, as the terminal's table).
Json IntervalBound(const ParameterEstimate& p, double bound) {
  return p.identifiable ? FiniteOrNull<Json>(bound) : Json(nullptr);
}

// Per-iteration sensitivities and estimates, in the page's units.
Json EstimatesJson(const std::vector<CampaignIteration>& iterations) {
  Json names = Json::array(), units = Json::array(), labels = Json::array(),
       log10 = Json::array(), value = Json::array(), low = Json::array(),
       high = Json::array();
  const std::vector<ParameterEstimate>& first =
      iterations[0].estimate.parameters;
  for (size_t k = 0; k < CampaignParameterCount(iterations[0]); ++k) {
    names.push_back(first[k].name);
    units.push_back(PageUnit(first[k].unit).first);
  }
  for (const CampaignIteration& it : iterations) {
    labels.push_back("iteration " + std::to_string(it.index) + " (" +
                     std::to_string(it.logs.size()) + " log" +
                     (it.logs.size() == 1 ? "" : "s") + "; " + it.model +
                     " model: " + it.failed_checks +
                     (it.action.empty() ? "" : ", " + it.action) + ")");
    Json l = Json::array(), v = Json::array(), lo = Json::array(),
         hi = Json::array();
    // The stiffnesses (an adopted effect's parameters follow them).
    const size_t count = std::min(names.size(), CampaignParameterCount(it));
    for (size_t k = 0; k < count; ++k) {
      const ParameterEstimate& p = it.estimate.parameters[k];
      const double scale = PageUnit(p.unit).second;
      l.push_back(FiniteOrNull<Json>(p.log10_inverse_information));
      v.push_back(p.value * scale);
      lo.push_back(IntervalBound(p, p.ci95_low * scale));
      hi.push_back(IntervalBound(p, p.ci95_high * scale));
    }
    log10.push_back(l);
    value.push_back(v);
    low.push_back(lo);
    high.push_back(hi);
  }
  return {{"parameters", names},
          {"iterations", labels},
          {"log10_diag_inv_jtj", log10},
          {"value", value},
          {"ci95_low", low},
          {"ci95_high", high},
          {"units", units}};
}

// The campaign's outcome for the page's summary: the final estimate (every
// parameter, the adopted effect's too, in the page's units; null bounds
// where no interval is given), the checks of its final estimate as the
// campaign judged them (CampaignCheck: "ok" or what fails) and whether it
// stopped, and each iteration's model, checks and action.
Json CampaignSummaryJson(const std::vector<CampaignIteration>& iterations) {
  const CampaignIteration& last = iterations.back();
  Json estimates = Json::array(), rows = Json::array();
  for (const ParameterEstimate& p : last.estimate.parameters) {
    const auto [unit, scale] = PageUnit(p.unit);
    estimates.push_back({{"name", p.name},
                         {"unit", unit},
                         {"value", FiniteOrNull<Json>(p.value * scale)},
                         {"ci95_low", IntervalBound(p, p.ci95_low * scale)},
                         {"ci95_high", IntervalBound(p, p.ci95_high * scale)},
                         {"at_bound", p.at_bound}});
  }
  for (const CampaignIteration& it : iterations) {
    rows.push_back({{"index", it.index},
                    {"logs", it.logs.size()},
                    {"model", it.model},
                    {"checks", it.failed_checks},
                    {"action", it.action}});
  }
  return {{"model", last.model},
          {"check", CampaignCheck(last)},
          {"action", last.action},
          {"adequacy_reason", last.estimate.adequacy.reason},
          {"estimates", estimates},
          {"iterations", rows}};
}

// A design run as the page draws it: the evaluated designs and the path.
Json RunJson(const DesignRun& run) {
  Json evaluated = Json::array(), path = Json::array();
  for (const DesignEvaluation& e : run.record) {
    evaluated.push_back({e.design.phi / kDegree, e.design.z_a, e.value});
  }
  for (const Design& d : run.result.path) {
    path.push_back({d.phi / kDegree, d.z_a});
  }
  return {{"optimizer", run.result.optimizer},
          {"evaluated", evaluated},
          {"path", path}};
}

// The page's panels of one design step's surface: one per criterion, the
// step's run on the surface of the criterion it optimised, and each
// criterion's value at the step's optimum.
void AddSurfaceJson(const CriterionSurface& surface, Criterion optimised,
                    const std::string& iteration, const DesignRun& run,
                    Json* out) {
  Json phi_axis = Json::array(), z_axis = Json::array();
  for (double phi : surface.phi) phi_axis.push_back(phi / kDegree);
  for (double z_a : surface.z_a) z_axis.push_back(z_a);
  const size_t np = surface.phi.size();
  const Design& optimum = run.result.best;
  for (size_t c = 0; c < surface.criteria.size(); ++c) {
    Json rows = Json::array();
    for (size_t j = 0; j < surface.z_a.size(); ++j) {
      Json row = Json::array();
      for (size_t i = 0; i < np; ++i) {
        row.push_back(FiniteOrNull<Json>(surface.grid[c][j * np + i]));
      }
      rows.push_back(row);
    }
    out->push_back(
        {{"criterion", CriterionName(surface.criteria[c])},
         {"iteration", iteration},
         {"phi_deg", phi_axis},
         {"z_a", z_axis},
         {"values", rows},
         {"runs", surface.criteria[c] == optimised ? Json::array({RunJson(run)})
                                                   : Json::array()},
         {"optimum",
          {{"phi_deg", optimum.phi / kDegree},
           {"z_a", optimum.z_a},
           {"value", FiniteOrNull<Json>(surface.at_points[c][0])}}}});
  }
}

// Reports a stage to the caller's callback; Interrupted() when it asks to
// stop.
Status Progress(const ReportOptions& options, const std::string& stage,
                double fraction) {
  if (options.callback &&
      options.callback({stage, fraction}) == CallbackReturn::kAbort) {
    return Interrupted("report");
  }
  return Status::Ok();
}

// The D and A surfaces (and the campaign's criterion when another) of each
// iteration that designed: the objective its optimizer searched, computed
// by the designer from the estimate and information matrix in the
// iteration's est.json.
Status SurfacesJson(const KcrigConfig& config, const fs::path& root,
                    Criterion criterion,
                    const std::vector<CampaignIteration>& iterations,
                    const ReportOptions& options, Json* out) {
  std::vector<Criterion> criteria = {Criterion::kD, Criterion::kA};
  if (std::find(criteria.begin(), criteria.end(), criterion) ==
      criteria.end()) {
    criteria.push_back(criterion);
  }
  const auto designed =
      std::count_if(iterations.begin(), iterations.end(),
                    [](const CampaignIteration& it) { return it.designed; });
  SurfaceOptions surface_options;
  surface_options.phi_points = options.surface_phi_points;
  surface_options.z_points = options.surface_z_points;
  *out = Json::array();
  int done = 0;
  for (const CampaignIteration& it : iterations) {
    if (!it.designed) continue;
    const std::string name = IterationName(root, it.index);
    KCRIG_RETURN_IF_ERROR(Progress(options, "criterion surfaces " + name,
                                   static_cast<double>(done++) / designed));
    const std::string est =
        (fs::path(CampaignIterationDir(root.string(), it.index)) / "est.json")
            .string();
    EstimateFile estimate;
    KCRIG_RETURN_IF_ERROR(ReadIterationEstimate(root, it.index, &estimate));
    if (estimate.information.size() == 0) {
      return Status::Error(est +
                           ": information_matrix: missing (the prior the "
                           "design searched with)");
    }
    // The design searched with the model parameters (an adopted effect's,
    // after them, were nuisance: StiffnessInformation).
    size_t n = 0;
    SuspensionParameters<double> names_only = config.model;
    while (n < estimate.names.size() &&
           FindParameter(&names_only, estimate.names[n]) != nullptr) {
      ++n;
    }
    DesignStepOptions step;
    step.names.assign(estimate.names.begin(), estimate.names.begin() + n);
    step.values.assign(estimate.values.begin(), estimate.values.begin() + n);
    step.prior_information =
        StiffnessInformation(estimate.information, static_cast<int>(n));
    step.objective.num_threads = options.num_threads;
    surface_options.points = {it.design.result.best};
    CriterionSurface surface;
    // The model the design searched with: an adopted freed parameter is
    // the model's own.
    KcrigConfig design_config = config;
    ApplyFreedParameters(estimate.names, estimate.values, &design_config.model);
    const Status status = ComputeCriterionSurface(design_config, step, criteria,
                                                  surface_options, &surface);
    if (!status.ok()) return Status::Error(est + ": " + status.message());
    AddSurfaceJson(surface, criterion, name, it.design, out);
  }
  return Status::Ok();
}

// The kriging surrogate refitted by the designer to the samples it had
// after its first, middle and last batch (the refinement of Fig. 2; batch 0
// is the start design alone), on the scale it fitted (ln for A, E, MM), from
// the first kriging design of the campaign.
Json KrigingJson(const KcrigConfig& config, const fs::path& root,
                 Criterion criterion,
                 const std::vector<CampaignIteration>& iterations) {
  const DesignBounds bounds{config.experiment.phi_bounds,
                            config.experiment.z_a_bounds};
  const Interval phi = bounds.phi, z = bounds.z_a;
  for (const CampaignIteration& it : iterations) {
    const std::vector<DesignEvaluation>& record = it.design.record;
    if (!it.designed || it.design.result.optimizer != "kriging" ||
        record.empty()) {
      continue;
    }
    const int last = std::max_element(record.begin(), record.end(),
                                      [](const DesignEvaluation& a,
                                         const DesignEvaluation& b) {
                                        return a.batch < b.batch;
                                      })
                         ->batch;
    std::vector<int> stages = {std::min(1, last), (last + 1) / 2, last};
    stages.erase(std::unique(stages.begin(), stages.end()), stages.end());
    Json panels = Json::array();
    const int np = 37, nz = 21;
    for (int stage : stages) {
      KrigingModel model;
      int samples = 0;
      if (!RefitSurrogate(record, criterion, bounds, stage, &model, &samples)
               .ok()) {
        continue;
      }
      Json points = Json::array();
      for (const DesignEvaluation& e : record) {
        if (e.batch <= stage) {
          points.push_back({e.design.phi / kDegree, e.design.z_a});
        }
      }
      Json rows = Json::array(), phi_axis = Json::array(),
           z_axis = Json::array();
      for (int i = 0; i < np; ++i) {
        phi_axis.push_back(
            (phi.lower + (phi.upper - phi.lower) * i / (np - 1)) / kDegree);
      }
      for (int j = 0; j < nz; ++j) {
        z_axis.push_back(z.lower + (z.upper - z.lower) * j / (nz - 1));
        Json row = Json::array();
        for (int i = 0; i < np; ++i) {
          row.push_back(model.Predict(
              Eigen::Vector2d(static_cast<double>(i) / (np - 1),
                              static_cast<double>(j) / (nz - 1))));
        }
        rows.push_back(row);
      }
      panels.push_back(
          {{"label", "after batch " + std::to_string(stage) + " (" +
                         std::to_string(samples) + " samples)"},
           {"phi_deg", phi_axis},
           {"z_a", z_axis},
           {"values", rows},
           {"points", points}});
    }
    if (panels.empty()) continue;
    const std::string name = CriterionName(criterion);
    const std::string scaled =
        OptimizationScale(criterion, 2.0) == 2.0 ? name : "ln " + name;
    return {{"criterion", scaled},
            {"iteration", IterationName(root, it.index)},
            {"panels", panels}};
  }
  return nullptr;
}

// One run's response-vs-force loops as the page draws them: per channel and
// branch the force along the excitation [kN] and the rig's and the model's
// readings (mm, deg), decimated.
Json LoopsJson(const RunSheet& run, const Experiment& e, int max_points) {
  Json branches = Json::array();
  for (int b = 0; b < 2; ++b) {
    const std::vector<int>& index = run.branches[b];
    if (index.empty()) continue;
    Json force = Json::array();
    Json rig = Json::array(), model = Json::array();
    for (int c = 0; c < 6; ++c) {
      rig.push_back(Json::array());
      model.push_back(Json::array());
    }
    for (size_t k : Decimation(index.size(), max_points)) {
      const int j = index[k];
      force.push_back(run.force_along[j] * 1e-3);
      for (int c = 0; c < 6; ++c) {
        rig[c].push_back(ChannelDisplayValue(c, e.measured[j](c)));
        model[c].push_back(ChannelDisplayValue(c, run.model_response[j](c)));
      }
    }
    branches.push_back({{"name", b == 0 ? "rising" : "falling"},
                        {"force", force},
                        {"rig", rig},
                        {"model", model}});
  }
  return {{"log", run.source}, {"branches", branches}};
}

// The K&C sheet of the campaign's runs against the model of the last
// iteration's est.json (its adopted effect included), and their loops.
Status KcJson(const KcrigConfig& config, const fs::path& root,
              const std::vector<CampaignIteration>& iterations,
              const ReportOptions& options, Json* out, ReportSummary* summary) {
  const fs::path est =
      fs::path(CampaignIterationDir(root.string(), iterations.back().index)) /
      "est.json";
  EstimateFile estimate;
  KCRIG_RETURN_IF_ERROR(ReadEstimateFile(est.string(), &estimate));
  // The model as it was fitted: at the step its fit needed.
  const double step = estimate.integrator_step > 0 ? estimate.integrator_step
                                                   : config.experiment.step;
  KcModel model;
  Status status =
      KcModelOfEstimate(config.model, estimate.names, estimate.values,
                        estimate.covariance, step, &model);
  if (!status.ok())
    return Status::Error(est.string() + ": " + status.message());
  std::vector<RunLog> logs(iterations.size());
  std::vector<Experiment> experiments(iterations.size());
  std::vector<KcRun> runs;
  for (size_t i = 0; i < iterations.size(); ++i) {
    const fs::path log =
        fs::path(CampaignIterationDir(root.string(), iterations[i].index)) /
        "run.csv";
    KCRIG_RETURN_IF_ERROR(
        LoadExperiment(log.string(), config, "", &experiments[i], &logs[i]));
    experiments[i].source = fs::relative(log, root).string();
    runs.push_back({&logs[i], &experiments[i]});
  }
  KcSheet sheet;
  KCRIG_RETURN_IF_ERROR(ComputeKcSheet(runs, &model, KcSheetOptions(), &sheet));
  for (int c = 0; c < 6; ++c) {
    if (sheet.channel_differs[c]) {
      summary->kc_differing_channels.push_back(kChannelNames[c]);
    }
  }
  Json loops = Json::array();
  for (size_t i = 0; i < sheet.runs.size(); ++i) {
    loops.push_back(
        LoopsJson(sheet.runs[i], experiments[i], options.max_plot_samples));
  }
  *out = {{"sheet", Json::parse(KcSheetToJson(sheet))}, {"loops", loops}};
  return Status::Ok();
}

// Where the final fit's model started each log (its est.json's
// rig_initial_state): the start, the tare's mean (mm, deg) and the Dahl
// forces kept from the run before [N]; null when that est.json has none.
Status InitialStatesJson(const fs::path& root,
                         const std::vector<CampaignIteration>& iterations,
                         Json* out) {
  EstimateFile estimate;
  KCRIG_RETURN_IF_ERROR(
      ReadIterationEstimate(root, iterations.back().index, &estimate));
  *out = nullptr;
  if (estimate.initial_states.empty()) return Status::Ok();
  Json channels = Json::array(), logs = Json::array();
  for (int k = 0; k < kNumChannels; ++k) {
    channels.push_back(std::string(kChannelNames[k]) + " [" +
                       ChannelDisplayUnit(k) + "]");
  }
  for (size_t i = 0; i < estimate.initial_states.size(); ++i) {
    const LogInitialState& s = estimate.initial_states[i];
    Json tare = nullptr, dahl = nullptr;
    if (s.tare) {
      tare = Json::array();
      for (int k = 0; k < kNumChannels; ++k) {
        tare.push_back(
            FiniteOrNull<Json>(ChannelDisplayValue(k, s.tare->mean(k))));
      }
    }
    if (!s.dahl_forces.empty()) {
      dahl = Json::array();
      for (double f : s.dahl_forces) dahl.push_back(FiniteOrNull<Json>(f));
    }
    // Named as the time histories name them (iteration_K/run.csv): est.json
    // has each path as the campaign was given it, from wherever it ran.
    const fs::path log =
        i < estimate.logs.size() ? fs::path(estimate.logs[i]) : fs::path();
    const std::string name =
        log.empty() ? "log " + std::to_string(i + 1)
                    : (log.parent_path().filename() / log.filename()).string();
    logs.push_back({{"log", name},
                    {"first_row_pose", s.from_first_row_pose},
                    {"tare_mean", tare},
                    {"dahl_force_N", dahl}});
  }
  *out = {{"iteration", iterations.back().index},
          {"channels", channels},
          {"bushings", kBushingChassisNames},
          {"logs", logs}};
  return Status::Ok();
}

// The isolability matrix the campaign wrote for its last iteration; null
// when there is none (a campaign run without --isolability).
Status IsolabilityJson(const fs::path& root,
                       const std::vector<CampaignIteration>& iterations,
                       Json* out) {
  const int last = iterations.back().index;
  const fs::path file =
      fs::path(CampaignIterationDir(root.string(), last)) / "isolability.json";
  *out = nullptr;
  if (!fs::exists(file)) return Status::Ok();
  Json doc;
  KCRIG_RETURN_IF_ERROR(ReadJsonFile(file.string(), &doc));
  const std::string where = file.string();
  std::vector<std::string> candidates;
  double min_share = 0;
  Json left;
  KCRIG_RETURN_IF_ERROR(ReadField(doc, "candidates", where, &candidates));
  KCRIG_RETURN_IF_ERROR(ReadField(doc, "min_share_left", where, &min_share));
  KCRIG_RETURN_IF_ERROR(ReadField(doc, "left", where, &left));
  const size_t n = candidates.size();
  bool square = left.is_array() && left.size() == n;
  for (size_t i = 0; square && i < n; ++i) {
    square = left[i].is_array() && left[i].size() == n;
    for (size_t j = 0; square && j < n; ++j) {
      square = left[i][j].is_null() || left[i][j].is_number();
    }
  }
  if (!square) {
    return Status::Error(where + ".left: expected " + std::to_string(n) +
                         " rows of " + std::to_string(n) +
                         " numbers or nulls, one per candidate");
  }
  if (!(min_share > 0 && min_share < 1)) {
    return Status::Error(where + ".min_share_left: not in (0, 1)");
  }
  *out = {{"iteration", last},
          {"candidates", candidates},
          {"left", left},
          {"min_share_left", min_share}};
  return Status::Ok();
}

// The campaign's figures: every experiment against the final estimate, the
// estimates per iteration, the criterion surfaces and the kriging surrogate.
Status CampaignJson(const KcrigConfig& config, const fs::path& root,
                    const ReportOptions& options, Json* data,
                    ReportSummary* summary) {
  Criterion criterion = Criterion::kD;
  std::vector<CampaignIteration> iterations;
  KCRIG_RETURN_IF_ERROR(ReadCampaign(root.string(), &criterion, &iterations));
  summary->campaign = true;
  (*data)["criterion"] = CriterionName(criterion);
  (*data)["estimates"] = EstimatesJson(iterations);
  (*data)["campaign_summary"] = CampaignSummaryJson(iterations);
  KCRIG_RETURN_IF_ERROR(
      InitialStatesJson(root, iterations, &(*data)["initial_states"]));
  Json experiments = Json::array();
  for (const CampaignIteration& it : iterations) {
    const fs::path log =
        fs::path(CampaignIterationDir(root.string(), it.index)) / "run.csv";
    KCRIG_RETURN_IF_ERROR(Progress(options,
                                   "time histories " +
                                       std::to_string(experiments.size() + 1) +
                                       "/" + std::to_string(iterations.size()),
                                   -1));
    Experiment e;
    KCRIG_RETURN_IF_ERROR(LoadExperiment(log.string(), config, "", &e));
    std::vector<Vec6<double>> model;
    const Status predicted =
        Predict(config, root, iterations.back(), e, &model);
    if (!predicted.ok()) {
      return Status::Error(log.string() + ": " + predicted.message());
    }
    Json histories = TimeHistories(e, model, options.max_plot_samples);
    histories["name"] = fs::relative(log, root).string();
    histories["phi_deg"] = it.experiment.phi / kDegree;
    histories["z_a"] = it.experiment.z_a;
    experiments.push_back(histories);
  }
  (*data)["experiments"] = experiments;
  (*data)["model_label"] = "model at the final estimate (iteration " +
                           std::to_string(iterations.back().index) + ")";
  summary->experiments = static_cast<int>(experiments.size());
  Json surfaces;
  KCRIG_RETURN_IF_ERROR(
      SurfacesJson(config, root, criterion, iterations, options, &surfaces));
  (*data)["surfaces"] = surfaces;
  (*data)["kriging"] = KrigingJson(config, root, criterion, iterations);
  KCRIG_RETURN_IF_ERROR(GuardedRead(root.string(), [&] {
    return IsolabilityJson(root, iterations, &(*data)["isolability"]);
  }));
  KCRIG_RETURN_IF_ERROR(Progress(options, "K&C sheet", -1));
  Json kc;
  KCRIG_RETURN_IF_ERROR(
      KcJson(config, root, iterations, options, &kc, summary));
  (*data)["kc"] = kc;
  return Status::Ok();
}

// Resolves a log path written in diag.json: beside it (a folder moved as a
// whole), else as written (relative to where diagnose ran).
fs::path LogPath(const fs::path& diag_file, const std::string& written) {
  const fs::path beside =
      diag_file.parent_path() / fs::path(written).filename();
  return fs::exists(beside) ? beside : fs::path(written);
}

// A candidate's figures as the page shows them (null: not computed).
Json CandidateRow(const CandidateScore& c) {
  return {{"model", c.model},
          {"score", FiniteOrNull<Json>(c.score)},
          {"gap_closed", FiniteOrNull<Json>(c.gap_closed)},
          {"bic", FiniteOrNull<Json>(c.bic)}};
}

Status DiagnosisJson(const KcrigConfig& config, const fs::path& file,
                     const ReportOptions& options, Json* out) {
  DiagnosisFile diag;
  KCRIG_RETURN_IF_ERROR(ReadDiagnosisFile(file.string(), &diag));
  const DiagnosisResult& d = diag.result;
  Json result = {{"file", file.string()},      {"verdict", d.verdict},
                 {"model", d.model},           {"components", d.components},
                 {"confidence", d.confidence}, {"reason", d.reason}};
  // Residual energy by channel x load regime: the mean squared weighted
  // residual (1 = noise) per channel in each slice.
  Json regimes = Json::array(), energy = Json::array();
  for (const std::vector<GapSlice>* group : {&d.magnitude, &d.direction}) {
    for (const GapSlice& slice : *group) {
      if (slice.samples == 0) continue;
      regimes.push_back(slice.name);
      Json row = Json::array();
      for (int k = 0; k < 6; ++k)
        row.push_back(FiniteOrNull<Json>(slice.channel_score(k)));
      energy.push_back(row);
    }
  }
  result["channels"] = kChannelNames;
  result["regimes"] = regimes;
  result["energy"] = energy;
  Json ranking = Json::array();
  const CandidateScore* chosen = nullptr;
  for (const CandidateScore& c : d.ranking) {
    if (!c.ok) continue;
    ranking.push_back(CandidateRow(c));
    if (c.model == d.model ||
        (chosen == nullptr && d.verdict == "unexplained")) {
      chosen = &c;
    }
  }
  if (diag.has_nominal) {
    result["nominal_score"] = FiniteOrNull<Json>(d.nominal.score);
    result["nominal_bic"] = FiniteOrNull<Json>(d.nominal.bic);
  }
  result["ranking"] = ranking;
  result["scoring"] = d.scoring;
  // Before / after on the held-out data (else the first training log).
  const bool on_holdout = !diag.holdout.empty();
  const std::vector<std::string>& logs = on_holdout ? diag.holdout : diag.logs;
  if (!logs.empty()) {
    result["overlay_on"] = on_holdout ? "held-out log" : "training log";
  }
  if (logs.empty() || chosen == nullptr || !diag.has_nominal) {
    *out = result;
    return Status::Ok();
  }
  const fs::path log = LogPath(file, logs[0]);
  Experiment e;
  const Status loaded =
      LoadExperiment(log.string(), config, options.dbc_file, &e);
  if (!loaded.ok()) {
    // The diagnosis stands without its overlay: say why it is missing.
    result["overlay_missing"] = loaded.message();
    *out = result;
    return Status::Ok();
  }
  // The estimator's default stiffness bounds, as the diagnosis uses them.
  const EstimatorOptions bounds;
  auto simulate = [&](const CandidateScore& candidate,
                      std::vector<Vec6<double>>* y) {
    EffectModel model;
    KCRIG_RETURN_IF_ERROR(EffectModel::CreateNamed(
        config.model, candidate.model, bounds.lower_scale, bounds.upper_scale,
        &model));
    const std::vector<double>& values = candidate.fit.values;
    if (static_cast<int>(values.size()) != model.num_parameters()) {
      return Status::Error(file.string() + ": candidate " + candidate.model +
                           " has " + std::to_string(values.size()) +
                           " parameters, the model " +
                           std::to_string(model.num_parameters()));
    }
    return SimulateEffectModel(model, values, e, config.experiment.step, y);
  };
  std::vector<Vec6<double>> before, after;
  KCRIG_RETURN_IF_ERROR(simulate(d.nominal, &before));
  KCRIG_RETURN_IF_ERROR(simulate(*chosen, &after));
  Json overlay = TimeHistories(e, before, options.max_plot_samples);
  const Json with = TimeHistories(e, after, options.max_plot_samples);
  for (size_t k = 0; k < overlay["channels"].size(); ++k) {
    overlay["channels"][k]["attributed"] = with["channels"][k]["model"];
    overlay["channels"][k]["attributed_residual"] =
        with["channels"][k]["residual"];
    overlay["channels"][k]["attributed_rms"] = with["channels"][k]["rms"];
  }
  overlay["log"] = log.filename().string();
  overlay["attributed_model"] = chosen->model;
  overlay["attributed"] = d.verdict != "unexplained";
  result["overlay"] = overlay;
  *out = result;
  return Status::Ok();
}

Json HistogramJson(const TimingPhase& phase) {
  Json x = Json::array(), y = Json::array();
  for (const auto& [lower, count] : phase.histogram_us) {
    x.push_back(lower);
    y.push_back(count);
  }
  return {{"us", x},
          {"count", y},
          {"p50_us", FiniteOrNull<Json>(phase.p50_us)},
          {"p99_us", FiniteOrNull<Json>(phase.p99_us)},
          {"p999_us", FiniteOrNull<Json>(phase.p999_us)},
          {"max_us", FiniteOrNull<Json>(phase.max_us)}};
}

// A timing.json as the page draws it: histograms against the budget.
Status TimingJson(const fs::path& root, const fs::path& file, Json* out) {
  TimingFile timing;
  KCRIG_RETURN_IF_ERROR(ReadTimingFile(file.string(), &timing));
  Json budget_us = Json::object();
  if (timing.budget_checked) {
    budget_us["wakeup"] = timing.wakeup_p99_us;
    budget_us["compute"] = timing.compute_p999_fraction * timing.period_us;
    budget_us["cycle"] = timing.cycle_p999_fraction * timing.period_us;
  }
  Json histograms = Json::object();
  for (const char* phase : {"wakeup", "compute", "cycle"}) {
    const auto found = timing.phases.find(phase);
    if (found != timing.phases.end()) {
      histograms[phase] = HistogramJson(found->second);
    }
  }
  *out = {{"source", fs::relative(file, root).string()},
          {"period_us", timing.period_us},
          {"cycles", timing.cycles},
          {"overruns", timing.overruns},
          {"skipped_cycles", timing.skipped_cycles},
          {"within_budget",
           timing.budget_checked ? Json(timing.within_budget) : Json(nullptr)},
          {"violations", timing.violations},
          {"budget_us", budget_us},
          {"histograms", histograms}};
  return Status::Ok();
}

// A count matrix (row -> column -> count) checked: an object whose rows are
// `rows` and whose counts are integers, in `columns` when it is given
// (else every column met is added to it).
Status CheckCounts(const Json& matrix, const std::string& where,
                   const std::vector<std::string>& rows,
                   std::vector<std::string>* columns) {
  if (!matrix.is_object()) return Status::Error(where + ": expected an object");
  const bool fixed = !columns->empty();
  for (const auto& [truth, row] : matrix.items()) {
    if (std::find(rows.begin(), rows.end(), truth) == rows.end() ||
        !row.is_object()) {
      return Status::Error(where + "." + truth + ": unknown row");
    }
    for (const auto& [column, count] : row.items()) {
      const bool known =
          std::find(columns->begin(), columns->end(), column) != columns->end();
      if (!count.is_number_integer() || (fixed && !known)) {
        return Status::Error(where + "." + truth + "." + column +
                             ": expected a count of a known column");
      }
      if (!known) columns->push_back(column);
    }
  }
  return Status::Ok();
}

// The page's heat map of a checked count matrix: rows, columns and counts
// in their order, 0 where the matrix has no cell.
Json CountGrid(const Json& matrix, const std::vector<std::string>& rows,
               const std::vector<std::string>& columns) {
  Json counts = Json::array();
  for (const std::string& truth : rows) {
    Json row = Json::array();
    for (const std::string& column : columns) {
      row.push_back(matrix[truth].value(column, 0));
    }
    counts.push_back(row);
  }
  return {{"rows", rows}, {"columns", columns}, {"counts", counts}};
}

// The figures the page's verdict line reads: each tally's hits and total,
// the confident wrong answers.
Status CheckFigures(const Json& figures, const std::string& where) {
  int count = 0;
  for (const auto& [name, hits] :
       {std::pair<const char*, const char*>{"library_effects_beyond_3_sigma",
                                            "correct"},
        {"clean", "none"},
        {"wrong_parameters_beyond_3_sigma", "named"},
        {"gap_closed_80_percent_when_correct", "closed"}}) {
    Json tally;
    KCRIG_RETURN_IF_ERROR(ReadField(figures, name, where, &tally));
    const std::string at = where + "." + name;
    KCRIG_RETURN_IF_ERROR(ReadField(tally, hits, at, &count));
    KCRIG_RETURN_IF_ERROR(ReadField(tally, "total", at, &count));
  }
  return ReadField(figures, "confident_wrong", where, &count);
}

// A validate.json as the page draws it: the confusion matrix as a grid of
// counts, the detection rate per class and size bin, and every case's size
// and outcome. Errors name the file and the field.
Status ValidationJson(const fs::path& root, const fs::path& file, Json* out) {
  Json doc;
  KCRIG_RETURN_IF_ERROR(ReadJsonFile(file.string(), &doc));
  const std::string where = file.string();
  Json confusion, power, figures, cases;
  for (const auto& [key, value] :
       {std::pair<const char*, Json*>{"confusion", &confusion},
        {"power", &power},
        {"figures", &figures}}) {
    KCRIG_RETURN_IF_ERROR(ReadField(doc, key, where, value));
    if (!value->is_object()) {
      return Status::Error(where + "." + key + ": expected an object");
    }
  }
  KCRIG_RETURN_IF_ERROR(CheckFigures(figures, where + ".figures"));
  KCRIG_RETURN_IF_ERROR(ReadField(doc, "case_results", where, &cases));
  if (!cases.is_array()) {
    return Status::Error(where + ".case_results: expected a list");
  }
  // The truths and verdicts in the order validate.json gives, so that the
  // diagonal reads as the correct verdicts.
  std::vector<std::string> order, rows, columns;
  KCRIG_RETURN_IF_ERROR(ReadField(doc, "confusion_rows", where, &order));
  KCRIG_RETURN_IF_ERROR(ReadField(doc, "confusion_columns", where, &columns));
  if (columns.empty()) {
    return Status::Error(where + ".confusion_columns: empty");
  }
  for (const std::string& truth : order) {
    if (confusion.contains(truth)) rows.push_back(truth);
  }
  KCRIG_RETURN_IF_ERROR(
      CheckCounts(confusion, where + ".confusion", rows, &columns));
  // Where the bushing effects act against where they were placed (absent
  // from files of earlier builds: no such figure then).
  const Json places = doc.value("component_confusion", Json::object());
  std::vector<std::string> place_rows, place_columns;
  for (const auto& [truth, row] : places.items()) place_rows.push_back(truth);
  KCRIG_RETURN_IF_ERROR(CheckCounts(places, where + ".component_confusion",
                                    place_rows, &place_columns));
  Json outcomes = Json::array();
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string at = where + ".case_results[" + std::to_string(i) + "]";
    std::string truth, verdict;
    double size = 0;
    bool correct = false, confident_wrong = false;
    KCRIG_RETURN_IF_ERROR(ReadField(cases[i], "truth", at, &truth));
    KCRIG_RETURN_IF_ERROR(ReadField(cases[i], "verdict", at, &verdict));
    KCRIG_RETURN_IF_ERROR(ReadField(cases[i], "size_sigma", at, &size));
    KCRIG_RETURN_IF_ERROR(ReadField(cases[i], "correct", at, &correct));
    KCRIG_RETURN_IF_ERROR(
        ReadField(cases[i], "confident_wrong", at, &confident_wrong));
    outcomes.push_back({{"truth", truth},
                        {"verdict", verdict},
                        {"size_sigma", size},
                        {"correct", correct},
                        {"confident_wrong", confident_wrong}});
  }
  *out = {{"source", fs::relative(file, root).string()},
          // As text: a JavaScript number would round a seed beyond 2^53.
          {"seed", doc.value("seed", Json(nullptr)).dump()},
          {"confusion", CountGrid(confusion, rows, columns)},
          {"places", CountGrid(places, place_rows, place_columns)},
          {"power", power},
          {"figures", figures},
          {"cases", outcomes}};
  return Status::Ok();
}

// The template with its three slots filled. The slots are found in the
// template itself, so nothing inserted (plotly, user data) is searched.
Status FillTemplate(const std::string& plotly, const std::string& data,
                    std::string* page) {
  const std::string page_template = kReportPageTemplate;
  std::string out;
  size_t from = 0;
  for (const auto& [slot, value] :
       {std::pair<std::string, const std::string*>{"/*KCRIG_PLOTLY*/", &plotly},
        {"/*KCRIG_DATA*/", &data},
        {"/*KCRIG_PAGE_SCRIPT*/", nullptr}}) {
    const size_t at = page_template.find(slot, from);
    if (at == std::string::npos) {
      return Status::Error("report template: slot " + slot + " missing");
    }
    out.append(page_template, from, at - from);
    out += value != nullptr ? *value : std::string(kReportPageScript);
    from = at + slot.size();
  }
  out.append(page_template, from, std::string::npos);
  *page = std::move(out);
  return Status::Ok();
}

}  // namespace

std::string KcSheetLine(const ReportSummary& summary) {
  if (summary.kc_differing_channels.empty()) {
    return "K&C sheet: the final model and the rig agree within 3 standard "
           "errors on every channel's gradient and loop width";
  }
  std::string channels;
  for (const std::string& c : summary.kc_differing_channels) {
    channels += (channels.empty() ? "" : ", ") + c;
  }
  return "K&C sheet: the final model and the rig differ (|z| > 3) on " +
         channels + " (the report's K&C sheet shows where)";
}

namespace {

Status ReadPlotly(const ReportOptions& options, std::string* plotly) {
  const char* plotly_override = std::getenv("KCRIG_PLOTLY_JS");
  const std::string plotly_path =
      plotly_override != nullptr ? plotly_override : options.plotly_js;
  std::ifstream plotly_in(plotly_path, std::ios::binary);
  if (!plotly_in) {
    return Status::Error(plotly_path +
                         ": plotly.js not found (Debian package "
                         "python3-plotly; scripts/setup.sh installs it; "
                         "KCRIG_PLOTLY_JS names another copy)");
  }
  std::stringstream text;
  text << plotly_in.rdbuf();
  *plotly = text.str();
  return Status::Ok();
}

// The diagnosis, timing and validation files anywhere in the folder, each
// kind sorted by path.
struct FolderFiles {
  std::vector<fs::path> diagnoses, timings, validations;
};

FolderFiles FindResultFiles(const fs::path& root) {
  FolderFiles files;
  for (const fs::directory_entry& entry :
       fs::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file()) continue;
    const std::string name = entry.path().filename().string();
    if (name == "diag.json") files.diagnoses.push_back(entry.path());
    if (name == "timing.json") files.timings.push_back(entry.path());
    if (name == "validate.json") files.validations.push_back(entry.path());
  }
  for (std::vector<fs::path>* kind :
       {&files.diagnoses, &files.timings, &files.validations}) {
    std::sort(kind->begin(), kind->end());
  }
  return files;
}

// data["diagnoses"], ["timings"], ["validations"] from the folder's files.
Status ResultFilesJson(const KcrigConfig& config, const fs::path& root,
                       const ReportOptions& options, Json* data,
                       ReportSummary* summary) {
  const FolderFiles files = FindResultFiles(root);
  Json diagnoses = Json::array();
  for (const fs::path& file : files.diagnoses) {
    KCRIG_RETURN_IF_ERROR(Progress(
        options, "diagnosis " + fs::relative(file, root).string(), -1));
    Json d;
    KCRIG_RETURN_IF_ERROR(GuardedRead(
        file, [&] { return DiagnosisJson(config, file, options, &d); }));
    diagnoses.push_back(d);
  }
  Json timings = Json::array();
  for (const fs::path& file : files.timings) {
    Json t;
    KCRIG_RETURN_IF_ERROR(TimingJson(root, file, &t));
    timings.push_back(t);
  }
  Json validations = Json::array();
  for (const fs::path& file : files.validations) {
    Json v;
    KCRIG_RETURN_IF_ERROR(
        GuardedRead(file, [&] { return ValidationJson(root, file, &v); }));
    validations.push_back(v);
  }
  summary->diagnosis = !diagnoses.empty();
  summary->timing = !timings.empty();
  summary->validation = !validations.empty();
  (*data)["diagnoses"] = diagnoses;
  (*data)["timings"] = timings;
  (*data)["validations"] = validations;
  return Status::Ok();
}

// The figures the page will draw (the browser test checks each rendered).
int ExpectedFigures(const Json& data, const ReportSummary& summary) {
  // JSON pointers: a key the page's data lacks counts as empty, never
  // indexes a const object out of its range.
  const auto size = [](const Json& node, const char* pointer) {
    const Json::json_pointer at(pointer);
    return node.contains(at) ? static_cast<int>(node.at(at).size()) : 0;
  };
  const auto drawn = [&data](const char* key) {
    return data.contains(key) && !data.at(key).is_null() ? 1 : 0;
  };
  int figures = 0;
  if (summary.campaign) {
    figures += summary.experiments + 2 + size(data, "/surfaces") +
               drawn("kriging") + drawn("isolability") +
               size(data, "/kc/loops");
  }
  for (const Json& d : data.value("diagnoses", Json::array())) {
    figures +=
        1 + (size(d, "/ranking") > 0 ? 1 : 0) + (d.contains("overlay") ? 1 : 0);
  }
  figures += size(data, "/timings");
  // Per validation: the confusion matrix, the cases and, unless every case
  // was clean, the power curve; with bushing effects, their places.
  for (const Json& v : data.value("validations", Json::array())) {
    figures +=
        (size(v, "/power") > 0 ? 3 : 2) + (size(v, "/places/rows") > 0 ? 1 : 0);
  }
  return figures;
}

// The page's data as a script's JSON: inside <script> a "</script" or
// "<!--" would change how the page parses, so every "<" (only ever inside
// JSON strings) is written escaped. Invalid UTF-8 (a file name) is
// replaced rather than thrown on.
std::string ScriptJson(const Json& data) {
  const std::string raw =
      data.dump(-1, ' ', false, Json::error_handler_t::replace);
  std::string json;
  json.reserve(raw.size());
  for (char c : raw) {
    if (c == '<') {
      json += "\\u003c";
    } else {
      json += c;
    }
  }
  return json;
}

}  // namespace

Status WriteReport(const KcrigConfig& config, const std::string& from_dir,
                   const std::string& html_path, const ReportOptions& options,
                   ReportSummary* summary) {
  *summary = ReportSummary();
  const fs::path root(from_dir);
  if (!fs::is_directory(root)) {
    return Status::Error(from_dir + ": not a folder");
  }
  std::string plotly;
  KCRIG_RETURN_IF_ERROR(ReadPlotly(options, &plotly));
  Json data;
  data["from"] = fs::absolute(root).lexically_normal().string();
  const std::time_t now = std::time(nullptr);
  char stamp[64];
  std::strftime(stamp, sizeof(stamp), "%Y-%m-%d %H:%M:%S UTC",
                std::gmtime(&now));
  data["generated"] = stamp;
  if (fs::exists(root / "campaign.json")) {
    KCRIG_RETURN_IF_ERROR(CampaignJson(config, root, options, &data, summary));
  }
  KCRIG_RETURN_IF_ERROR(ResultFilesJson(config, root, options, &data, summary));
  if (!summary->campaign && !summary->diagnosis && !summary->timing &&
      !summary->validation) {
    return Status::Error(from_dir +
                         ": no campaign.json, diag.json, timing.json or "
                         "validate.json to report on");
  }
  summary->figures = ExpectedFigures(data, *summary);
  data["expected_figures"] = summary->figures;
  std::string page;
  KCRIG_RETURN_IF_ERROR(FillTemplate(plotly, ScriptJson(data), &page));
  return WriteFilesAtomically({{html_path, page}});
}

}  // namespace kcrig
