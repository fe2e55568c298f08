#include "report/report.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>

#include "base/parallel_for.h"
#include "designer/criteria.h"
#include "designer/design_objective.h"
#include "designer/information.h"
#include "designer/kriging.h"
#include "diagnosis/effect_model.h"
#include "estimator/estimator.h"
#include "estimator/experiment.h"
#include "nlohmann/json.hpp"
#include "records/run_log.h"
#include "report/report_page.h"
#include "rt_core/model/channels.h"
#include "rt_core/model/plant_effects.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

Status ReadJsonFile(const fs::path& path, Json* doc) {
  std::ifstream in(path);
  if (!in) return Status::Error(path.string() + ": cannot open");
  try {
    *doc = Json::parse(in);
  } catch (const Json::exception& e) {
    return Status::Error(path.string() + ": not valid JSON (" + e.what() + ")");
  }
  return Status::Ok();
}

// A JSON field read with its file and path in the error, never a throw
// across the module boundary.
template <typename T>
Status Field(const Json& node, const std::string& key, const std::string& where,
             T* value) {
  if (!node.is_object() || !node.contains(key)) {
    return Status::Error(where + ": missing field '" + key + "'");
  }
  try {
    *value = node.at(key).get<T>();
  } catch (const Json::exception&) {
    return Status::Error(where + "." + key + ": unexpected type (" +
                         node.at(key).type_name() + ")");
  }
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(*value)) {
      return Status::Error(where + "." + key + ": not a finite number");
    }
  }
  return Status::Ok();
}

// Runs `read`, which reads `file`: JSON of a shape the field checks did not
// anticipate (an array where an object belongs, a string for a number)
// becomes an error naming the file instead of an exception.
template <typename Read>
Status Guarded(const fs::path& file, Read&& read) {
  try {
    return read();
  } catch (const Json::exception& e) {
    return Status::Error(file.string() + ": unexpected content (" + e.what() +
                         ")");
  }
}

// The rows of `rows` that start with `width` numbers (the others dropped):
// what the page plots from a file's point lists.
Json NumberRows(const Json& rows, size_t width) {
  Json out = Json::array();
  if (!rows.is_array()) return out;
  for (const Json& row : rows) {
    if (!row.is_array() || row.size() < width) continue;
    bool numbers = true;
    for (size_t i = 0; i < width; ++i) numbers = numbers && row[i].is_number();
    if (numbers) out.push_back(row);
  }
  return out;
}

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

// The config's model with `names` set to `values` (an estimate).
Status ModelWith(const SuspensionParameters<double>& nominal,
                 const std::vector<std::pair<std::string, double>>& values,
                 SuspensionParameters<double>* model) {
  *model = nominal;
  for (const auto& [name, value] : values) {
    double* parameter = FindParameter(model, name);
    if (parameter == nullptr) {
      return Status::Error("unknown parameter '" + name + "'");
    }
    *parameter = value;
  }
  return Status::Ok();
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

// What the nominal model (bushings from `estimate`) predicts for `e`.
Status Predict(const KcrigConfig& config,
               const std::vector<std::pair<std::string, double>>& estimate,
               const Experiment& e, std::vector<Vec6<double>>* sensed) {
  SuspensionParameters<double> model;
  Status status = ModelWith(config.model, estimate, &model);
  if (!status.ok()) return status;
  EffectModel nominal;
  // The estimator's default stiffness bounds, as the diagnosis uses them.
  const EstimatorOptions bounds;
  status = EffectModel::Create(model, {}, bounds.lower_scale,
                               bounds.upper_scale, &nominal);
  if (!status.ok()) return status;
  std::vector<double> values;
  for (int i = 0; i < kNumBushings; ++i) {
    values.push_back(model.bushings[i].stiffness);
  }
  return SimulateEffectModel(nominal, values, e, config.experiment.step,
                             sensed);
}

// An iteration's design.json: the criterion it optimised and its runs
// (empty when the iteration designed nothing, the last one).
struct DesignFile {
  std::string name;  // the iteration folder, e.g. "iteration_0"
  Criterion criterion = Criterion::kD;
  std::string criterion_name;
  Json runs = Json::array();
};

struct CampaignData {
  Json doc;
  std::vector<fs::path> iteration_dirs;
  std::vector<std::vector<std::pair<std::string, double>>> estimates;
  std::vector<Design> designs;           // of the experiments run
  std::vector<DesignFile> design_files;  // of the iterations that designed
};

// Reads `file` when it exists (appending it to `designs`).
Status ReadDesignFile(const fs::path& file, std::vector<DesignFile>* designs) {
  if (!fs::exists(file)) return Status::Ok();
  Json doc;
  Status status = ReadJsonFile(file, &doc);
  if (!status.ok()) return status;
  DesignFile design;
  design.name = file.parent_path().filename().string();
  status = Field(doc, "criterion", file.string(), &design.criterion_name);
  if (!status.ok()) return status;
  status = ParseCriterion(design.criterion_name, &design.criterion);
  if (!status.ok())
    return Status::Error(file.string() + ": " + status.message());
  if (doc.contains("runs") && doc["runs"].is_array()) {
    for (const Json& run : doc["runs"]) {
      if (run.is_object()) design.runs.push_back(run);
    }
  }
  designs->push_back(std::move(design));
  return Status::Ok();
}

Status ReadCampaign(const fs::path& dir, CampaignData* data) {
  const fs::path file = dir / "campaign.json";
  Status status = ReadJsonFile(file, &data->doc);
  if (!status.ok()) return status;
  Json iterations;
  status = Field(data->doc, "iterations", file.string(), &iterations);
  if (!status.ok()) return status;
  if (!iterations.is_array() || iterations.empty()) {
    return Status::Error(file.string() + ": iterations: no iteration");
  }
  for (size_t k = 0; k < iterations.size(); ++k) {
    const std::string where =
        file.string() + ": iterations[" + std::to_string(k) + "]";
    const Json& it = iterations[k];
    int index = 0;
    Json experiment, parameters;
    double phi_deg = 0, z_a = 0;
    for (Status s : {Field(it, "iteration", where, &index),
                     Field(it, "experiment", where, &experiment),
                     Field(it, "parameters", where, &parameters)}) {
      if (!s.ok()) return s;
    }
    for (Status s :
         {Field(experiment, "phi_deg", where + ".experiment", &phi_deg),
          Field(experiment, "z_a", where + ".experiment", &z_a)}) {
      if (!s.ok()) return s;
    }
    std::vector<std::pair<std::string, double>> estimate;
    for (size_t i = 0; i < parameters.size(); ++i) {
      const std::string at = where + ".parameters[" + std::to_string(i) + "]";
      std::string name;
      double value = 0;
      for (Status s : {Field(parameters[i], "name", at, &name),
                       Field(parameters[i], "value", at, &value)}) {
        if (!s.ok()) return s;
      }
      estimate.emplace_back(name, value);
    }
    data->iteration_dirs.push_back(dir /
                                   ("iteration_" + std::to_string(index)));
    status = ReadDesignFile(data->iteration_dirs.back() / "design.json",
                            &data->design_files);
    if (!status.ok()) return status;
    data->estimates.push_back(estimate);
    data->designs.push_back({phi_deg * kDegree, z_a});
  }
  return Status::Ok();
}

// A parameter's unit as engineers read it and the factor from SI to it.
std::pair<std::string, double> DisplayUnit(const std::string& si) {
  if (si == "N/m") return {"N/mm", 1e-3};
  if (si == "N s/m") return {"N s/mm", 1e-3};
  if (si == "m") return {"mm", 1e3};
  return {si, 1.0};
}

// Per-iteration sensitivities and estimates, in the page's units.
Json EstimatesJson(const CampaignData& data) {
  const Json& iterations = data.doc["iterations"];
  Json names = Json::array(), units = Json::array(), labels = Json::array(),
       log10 = Json::array(), value = Json::array(), low = Json::array(),
       high = Json::array();
  for (const Json& p : iterations[0]["parameters"]) {
    names.push_back(p["name"]);
    units.push_back(DisplayUnit(p.value("unit", "")).first);
  }
  for (const Json& it : iterations) {
    labels.push_back(
        "iteration " + std::to_string(it["iteration"].get<int>()) + " (" +
        std::to_string(it.value("logs", Json::array()).size()) + " log" +
        (it.value("logs", Json::array()).size() == 1 ? "" : "s") + ")");
    Json l = Json::array(), v = Json::array(), lo = Json::array(),
         hi = Json::array();
    for (const Json& p : it["parameters"]) {
      l.push_back(p.value("log10_diag_inv_jtj", Json(nullptr)));
      const double scale = DisplayUnit(p.value("unit", "")).second;
      v.push_back(p["value"].get<double>() * scale);
      if (p.contains("ci95") && p["ci95"].is_array() && p["ci95"].size() == 2 &&
          p["ci95"][0].is_number() && p["ci95"][1].is_number()) {
        lo.push_back(p["ci95"][0].get<double>() * scale);
        hi.push_back(p["ci95"][1].get<double>() * scale);
      } else {
        lo.push_back(nullptr);
        hi.push_back(nullptr);
      }
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

// The D and A surfaces over the design box at the first estimate, with the
// information of the first experiment as the prior (what the first design
// was chosen on), and the first design's evaluated points and paths.
Status SurfacesJson(const KcrigConfig& config, const CampaignData& data,
                    const ReportOptions& options, Json* out) {
  std::vector<std::string> names;
  std::vector<double> values;
  for (const auto& [name, value] : data.estimates[0]) {
    names.push_back(name);
    values.push_back(value);
  }
  std::unique_ptr<InformationEvaluator> no_prior, with_prior;
  const int p = static_cast<int>(names.size());
  Status status = InformationEvaluator::Create(
      config.model, names, values, config.experiment,
      Eigen::MatrixXd::Zero(p, p), &no_prior);
  if (!status.ok()) return status;
  Eigen::MatrixXd prior;
  status = no_prior->Information(data.designs[0], true, &prior);
  if (!status.ok()) return status;
  status = InformationEvaluator::Create(config.model, names, values,
                                        config.experiment, prior, &with_prior);
  if (!status.ok()) return status;
  // The first design's runs go on the surface of their criterion, which is
  // drawn beside D and A when it is another (E, MM).
  const DesignFile* first =
      !data.design_files.empty() &&
              data.design_files[0].name ==
                  data.iteration_dirs[0].filename().string()
          ? &data.design_files[0]
          : nullptr;
  std::vector<Criterion> criteria = {Criterion::kD, Criterion::kA};
  if (first != nullptr && std::find(criteria.begin(), criteria.end(),
                                    first->criterion) == criteria.end()) {
    criteria.push_back(first->criterion);
  }
  const Interval phi = config.experiment.phi_bounds;
  const Interval z = config.experiment.z_a_bounds;
  const int np = std::max(2, options.surface_phi_points);
  const int nz = std::max(2, options.surface_z_points);
  const int points = np * nz;
  auto design_at = [&](int i, int j) {
    return Design{phi.lower + (phi.upper - phi.lower) * i / (np - 1),
                  z.lower + (z.upper - z.lower) * j / (nz - 1)};
  };
  // One information matrix per point serves every criterion. A point whose
  // simulation fails (diverges) is left empty, not fatal.
  std::vector<std::vector<double>> surface(
      criteria.size(),
      std::vector<double>(points, std::numeric_limits<double>::quiet_NaN()));
  std::mutex progress_mutex;
  int done = 0;
  auto progress = [&](int finished) {
    if (!options.on_progress) return;
    options.on_progress("criterion surfaces " + std::to_string(finished) + "/" +
                            std::to_string(points),
                        static_cast<double>(finished) / points);
  };
  progress(0);
  ParallelFor(points, options.num_threads, [&](int job) {
    Eigen::MatrixXd information;
    if (with_prior
            ->Information(design_at(job % np, job / np), false, &information)
            .ok()) {
      for (size_t c = 0; c < criteria.size(); ++c) {
        surface[c][job] = EvaluateCriterion(criteria[c], information).value;
      }
    }
    std::lock_guard<std::mutex> lock(progress_mutex);
    if (++done % 10 == 0 || done == points) progress(done);
  });
  Json phi_axis = Json::array(), z_axis = Json::array();
  for (int i = 0; i < np; ++i)
    phi_axis.push_back(design_at(i, 0).phi / kDegree);
  for (int j = 0; j < nz; ++j) z_axis.push_back(design_at(0, j).z_a);
  *out = Json::array();
  for (size_t c = 0; c < criteria.size(); ++c) {
    Json rows = Json::array();
    for (int j = 0; j < nz; ++j) {
      Json row = Json::array();
      for (int i = 0; i < np; ++i) {
        const double v = surface[c][j * np + i];
        row.push_back(std::isfinite(v) ? Json(v) : Json(nullptr));
      }
      rows.push_back(row);
    }
    Json runs = Json::array();
    if (first != nullptr && first->criterion == criteria[c]) {
      for (const Json& run : first->runs) {
        runs.push_back(
            {{"optimizer", run.value("optimizer", "")},
             {"evaluated", NumberRows(run.value("evaluated", Json()), 3)},
             {"path", NumberRows(run.value("path", Json()), 2)}});
      }
    }
    out->push_back({{"criterion", CriterionName(criteria[c])},
                    {"phi_deg", phi_axis},
                    {"z_a", z_axis},
                    {"values", rows},
                    {"runs", runs}});
  }
  return Status::Ok();
}

// The kriging surrogate refitted to the samples the designer had after its
// first, middle and last batch (the refinement of Fig. 2; batch 0 is the
// start design alone), on the scale the designer fitted (ln for A, E, MM),
// from the first kriging design run of the campaign.
Json KrigingJson(const KcrigConfig& config, const CampaignData& data) {
  for (const DesignFile& design : data.design_files) {
    for (const Json& run : design.runs) {
      if (run.value("optimizer", "") != "kriging") continue;
      const Interval phi = config.experiment.phi_bounds;
      const Interval z = config.experiment.z_a_bounds;
      std::vector<Eigen::Vector2d> x;
      std::vector<double> y;
      std::vector<int> batch;
      Json shown = Json::array();
      for (const Json& row : NumberRows(run.value("evaluated", Json()), 4)) {
        const double phi_deg = row[0], z_a = row[1], value = row[2];
        if (!std::isfinite(value)) continue;
        x.emplace_back(
            (phi_deg * kDegree - phi.lower) / (phi.upper - phi.lower),
            (z_a - z.lower) / (z.upper - z.lower));
        y.push_back(OptimizationScale(design.criterion, value));
        batch.push_back(row[3].get<int>());
        shown.push_back({phi_deg, z_a});
      }
      if (x.empty()) continue;
      const int last = *std::max_element(batch.begin(), batch.end());
      std::vector<int> stages = {std::min(1, last), (last + 1) / 2, last};
      stages.erase(std::unique(stages.begin(), stages.end()), stages.end());
      Json panels = Json::array();
      const int np = 37, nz = 21;
      for (int stage : stages) {
        std::vector<Eigen::Vector2d> xs;
        std::vector<double> ys;
        Json points = Json::array();
        for (size_t k = 0; k < x.size(); ++k) {
          if (batch[k] > stage) continue;
          xs.push_back(x[k]);
          ys.push_back(y[k]);
          points.push_back(shown[k]);
        }
        KrigingModel model;
        if (!model.Fit(xs, ys, KrigingOptions()).ok()) continue;
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
                           std::to_string(xs.size()) + " samples)"},
             {"phi_deg", phi_axis},
             {"z_a", z_axis},
             {"values", rows},
             {"points", points}});
      }
      if (panels.empty()) continue;
      const std::string scaled = OptimizationScale(design.criterion, 2.0) == 2.0
                                     ? design.criterion_name
                                     : "ln " + design.criterion_name;
      return {{"criterion", scaled},
              {"iteration", design.name},
              {"panels", panels}};
    }
  }
  return nullptr;
}

// Resolves a log path written in diag.json: beside it (a folder moved as a
// whole), else as written (relative to where diagnose ran).
fs::path LogPath(const fs::path& diag_file, const std::string& written) {
  const fs::path beside =
      diag_file.parent_path() / fs::path(written).filename();
  return fs::exists(beside) ? beside : fs::path(written);
}

Status DiagnosisJson(const KcrigConfig& config, const fs::path& file,
                     const ReportOptions& options, Json* out) {
  Json diag;
  Status status = ReadJsonFile(file, &diag);
  if (!status.ok()) return status;
  std::string verdict, confidence, reason;
  for (Status s : {Field(diag, "verdict", file.string(), &verdict),
                   Field(diag, "reason", file.string(), &reason)}) {
    if (!s.ok()) return s;
  }
  confidence = diag.value("confidence", "");
  Json result = {{"file", file.string()},
                 {"verdict", verdict},
                 {"confidence", confidence},
                 {"reason", reason}};
  // Residual energy by channel x load regime: the mean squared weighted
  // residual (1 = noise) per channel in each slice.
  const Json& localisation = diag.value("localisation", Json::object());
  Json regimes = Json::array(), energy = Json::array();
  for (const char* group : {"load_magnitude", "load_direction"}) {
    for (const Json& slice : localisation.value(group, Json::array())) {
      if (slice.value("samples", 0) == 0) continue;
      regimes.push_back(slice.value("name", ""));
      Json row = Json::array();
      const Json& per = slice.value("score_per_channel", Json::object());
      for (const char* c : kChannelNames)
        row.push_back(per.value(c, Json(nullptr)));
      energy.push_back(row);
    }
  }
  result["channels"] = kChannelNames;
  result["regimes"] = regimes;
  result["energy"] = energy;
  Json ranking = Json::array();
  const Json* chosen = nullptr;
  const Json candidates = diag.value("candidates", Json::array());
  for (const Json& c : candidates) {
    if (!c.value("ok", false)) continue;
    ranking.push_back({{"model", c.value("model", "")},
                       {"score", c.value("score", Json(nullptr))},
                       {"gap_closed", c.value("gap_closed", Json(nullptr))},
                       {"bic", c.value("bic", Json(nullptr))}});
    if (c.value("model", "") == verdict ||
        (chosen == nullptr && verdict == "unexplained")) {
      chosen = &c;
    }
  }
  if (diag.contains("nominal")) {
    result["nominal_score"] = diag["nominal"].value("score", Json(nullptr));
    result["nominal_bic"] = diag["nominal"].value("bic", Json(nullptr));
  }
  result["ranking"] = ranking;
  result["scoring"] = diag.value("scoring", "");
  // Before / after on the held-out data (else the first training log).
  std::vector<std::string> logs;
  for (const char* key : {"holdout", "logs"}) {
    for (const Json& l : diag.value(key, Json::array())) {
      if (l.is_string()) logs.push_back(l.get<std::string>());
    }
    if (!logs.empty()) {
      result["overlay_on"] =
          std::string(key) == "holdout" ? "held-out log" : "training log";
      break;
    }
  }
  if (logs.empty() || chosen == nullptr || !diag.contains("nominal")) {
    *out = result;
    return Status::Ok();
  }
  const fs::path log = LogPath(file, logs[0]);
  Experiment e;
  status = LoadExperiment(log.string(), config, options.dbc_file, &e);
  if (!status.ok()) {
    // The diagnosis stands without its overlay: say why it is missing.
    result["overlay_missing"] = status.message();
    *out = result;
    return Status::Ok();
  }
  // The estimator's default stiffness bounds, as the diagnosis uses them.
  const EstimatorOptions bounds;
  auto simulate = [&](const Json& candidate, std::vector<Vec6<double>>* y) {
    const std::string name = candidate.value("model", "nominal");
    EffectModel model;
    Status made = EffectModel::CreateNamed(
        config.model, name, bounds.lower_scale, bounds.upper_scale, &model);
    if (!made.ok()) return made;
    const Json& parameters = candidate.value("parameters", Json::array());
    if (static_cast<int>(parameters.size()) != model.num_parameters()) {
      return Status::Error(file.string() + ": candidate " + name + " has " +
                           std::to_string(parameters.size()) +
                           " parameters, the model " +
                           std::to_string(model.num_parameters()));
    }
    std::vector<double> values;
    for (const Json& p : parameters) {
      double v = 0;
      Status s = Field(p, "value", file.string() + ": " + name, &v);
      if (!s.ok()) return s;
      values.push_back(v);
    }
    return SimulateEffectModel(model, values, e, config.experiment.step, y);
  };
  std::vector<Vec6<double>> before, after;
  status = simulate(diag["nominal"], &before);
  if (!status.ok()) return status;
  status = simulate(*chosen, &after);
  if (!status.ok()) return status;
  Json overlay = TimeHistories(e, before, options.max_plot_samples);
  const Json with = TimeHistories(e, after, options.max_plot_samples);
  for (size_t k = 0; k < overlay["channels"].size(); ++k) {
    overlay["channels"][k]["attributed"] = with["channels"][k]["model"];
    overlay["channels"][k]["attributed_residual"] =
        with["channels"][k]["residual"];
    overlay["channels"][k]["attributed_rms"] = with["channels"][k]["rms"];
  }
  overlay["log"] = log.filename().string();
  overlay["attributed_model"] = chosen->value("model", "");
  overlay["attributed"] = verdict != "unexplained";
  result["overlay"] = overlay;
  *out = result;
  return Status::Ok();
}

Json HistogramJson(const Json& phase) {
  Json x = Json::array(), y = Json::array();
  for (const Json& bin : phase.value("histogram_us", Json::array())) {
    if (!bin.is_array() || bin.size() != 2) continue;
    x.push_back(bin[0]);
    y.push_back(bin[1]);
  }
  return {{"us", x},
          {"count", y},
          {"p50_us", phase.value("p50_us", Json(nullptr))},
          {"p99_us", phase.value("p99_us", Json(nullptr))},
          {"p999_us", phase.value("p999_us", Json(nullptr))},
          {"max_us", phase.value("max_us", Json(nullptr))}};
}

Status TimingJson(const fs::path& root, const fs::path& file, Json* out) {
  Json doc;
  Status status = ReadJsonFile(file, &doc);
  if (!status.ok()) return status;
  double period = 0;
  Json phases;
  for (Status s : {Field(doc, "period_us", file.string(), &period),
                   Field(doc, "phases", file.string(), &phases)}) {
    if (!s.ok()) return s;
  }
  const Json& budget = doc.value("budget", Json::object());
  Json budget_us = Json::object();
  if (budget.contains("wakeup_p99_us")) {
    budget_us["wakeup"] = budget["wakeup_p99_us"];
  }
  if (budget.contains("compute_p999_fraction")) {
    budget_us["compute"] =
        budget["compute_p999_fraction"].get<double>() * period;
  }
  if (budget.contains("cycle_p999_fraction")) {
    budget_us["cycle"] = budget["cycle_p999_fraction"].get<double>() * period;
  }
  Json histograms = Json::object();
  for (const char* phase : {"wakeup", "compute", "cycle"}) {
    if (phases.contains(phase))
      histograms[phase] = HistogramJson(phases[phase]);
  }
  *out = {{"source", fs::relative(file, root).string()},
          {"period_us", period},
          {"cycles", doc.value("cycles", 0)},
          {"overruns", doc.value("overruns", 0)},
          {"skipped_cycles", doc.value("skipped_cycles", 0)},
          {"within_budget", budget.value("within", Json(nullptr))},
          {"violations", budget.value("violations", Json::array())},
          {"budget_us", budget_us},
          {"histograms", histograms}};
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

Status WriteReport(const KcrigConfig& config, const std::string& from_dir,
                   const std::string& html_path, const ReportOptions& options,
                   ReportSummary* summary) {
  *summary = ReportSummary();
  const fs::path root(from_dir);
  if (!fs::is_directory(root)) {
    return Status::Error(from_dir + ": not a folder");
  }
  auto progress = [&](const std::string& text) {
    if (options.on_progress) options.on_progress(text, -1);
  };
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
  std::stringstream plotly;
  plotly << plotly_in.rdbuf();

  Json data;
  data["from"] = fs::absolute(root).lexically_normal().string();
  const std::time_t now = std::time(nullptr);
  char stamp[64];
  std::strftime(stamp, sizeof(stamp), "%Y-%m-%d %H:%M:%S UTC",
                std::gmtime(&now));
  data["generated"] = stamp;

  Status status;
  if (fs::exists(root / "campaign.json")) {
    status = Guarded(root / "campaign.json", [&] {
      CampaignData campaign;
      Status read = ReadCampaign(root, &campaign);
      if (!read.ok()) return read;
      summary->campaign = true;
      data["criterion"] = campaign.doc.value("criterion", "");
      data["estimates"] = EstimatesJson(campaign);
      // Every experiment against the final estimate.
      const auto& final_estimate = campaign.estimates.back();
      Json experiments = Json::array();
      for (size_t k = 0; k < campaign.iteration_dirs.size(); ++k) {
        const fs::path log = campaign.iteration_dirs[k] / "run.csv";
        progress("time histories " + std::to_string(k + 1) + "/" +
                 std::to_string(campaign.iteration_dirs.size()));
        Experiment e;
        read = LoadExperiment(log.string(), config, "", &e);
        if (!read.ok()) return read;
        std::vector<Vec6<double>> model;
        read = Predict(config, final_estimate, e, &model);
        if (!read.ok()) {
          return Status::Error(log.string() + ": " + read.message());
        }
        Json histories = TimeHistories(e, model, options.max_plot_samples);
        histories["name"] = fs::relative(log, root).string();
        histories["phi_deg"] = campaign.designs[k].phi / kDegree;
        histories["z_a"] = campaign.designs[k].z_a;
        experiments.push_back(histories);
      }
      data["experiments"] = experiments;
      data["model_label"] = "model at the final estimate (iteration " +
                            std::to_string(campaign.iteration_dirs.size() - 1) +
                            ")";
      summary->experiments = static_cast<int>(experiments.size());
      Json surfaces;
      read = SurfacesJson(config, campaign, options, &surfaces);
      if (!read.ok()) return read;
      data["surfaces"] = surfaces;
      data["kriging"] = KrigingJson(config, campaign);
      return Status::Ok();
    });
    if (!status.ok()) return status;
  }
  // Diagnosis and timing files anywhere in the folder.
  std::vector<fs::path> diag_files, timing_files;
  for (const fs::directory_entry& entry :
       fs::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file()) continue;
    const std::string name = entry.path().filename().string();
    if (name == "diag.json") diag_files.push_back(entry.path());
    if (name == "timing.json") timing_files.push_back(entry.path());
  }
  std::sort(diag_files.begin(), diag_files.end());
  std::sort(timing_files.begin(), timing_files.end());
  Json diagnoses = Json::array();
  for (const fs::path& file : diag_files) {
    progress("diagnosis " + fs::relative(file, root).string());
    Json d;
    status =
        Guarded(file, [&] { return DiagnosisJson(config, file, options, &d); });
    if (!status.ok()) return status;
    diagnoses.push_back(d);
  }
  data["diagnoses"] = diagnoses;
  summary->diagnosis = !diagnoses.empty();
  Json timings = Json::array();
  for (const fs::path& file : timing_files) {
    Json t;
    status = Guarded(file, [&] { return TimingJson(root, file, &t); });
    if (!status.ok()) return status;
    timings.push_back(t);
  }
  data["timings"] = timings;
  summary->timing = !timings.empty();
  if (!summary->campaign && !summary->diagnosis && !summary->timing) {
    return Status::Error(from_dir +
                         ": no campaign.json, diag.json or timing.json to "
                         "report on");
  }
  // Figures the page will draw (the browser test checks each rendered).
  int figures = 0;
  if (summary->campaign) {
    figures += summary->experiments + 2 +
               static_cast<int>(data["surfaces"].size()) +
               (data["kriging"].is_null() ? 0 : 1);
  }
  for (const Json& d : diagnoses) {
    figures +=
        1 + (d["ranking"].empty() ? 0 : 1) + (d.contains("overlay") ? 1 : 0);
  }
  figures += static_cast<int>(timings.size());
  summary->figures = figures;
  data["expected_figures"] = figures;

  // Inside <script> a "</script" or "<!--" would change how the page
  // parses: every "<" (only ever inside JSON strings) is written escaped.
  // Invalid UTF-8 (a file name) is replaced rather than thrown on.
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
  std::string page;
  status = FillTemplate(plotly.str(), json, &page);
  if (!status.ok()) return status;
  return WriteFilesAtomically({{html_path, page}});
}

}  // namespace kcrig
