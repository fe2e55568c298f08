#include "report/report.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <sstream>
#include <thread>

#include "designer/criteria.h"
#include "designer/design_objective.h"
#include "designer/information.h"
#include "designer/kriging.h"
#include "estimator/effect_model.h"
#include "estimator/estimator.h"
#include "estimator/experiment.h"
#include "io_drivers/run_log.h"
#include "nlohmann/json.hpp"
#include "report/report_page.h"
#include "rt_core/plant_effects.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr double kDegree = std::numbers::pi / 180.0;
constexpr const char* kChannels[6] = {"x", "y", "z", "toe", "camber", "caster"};
constexpr const char* kChannelUnits[6] = {"mm",  "mm",  "mm",
                                          "deg", "deg", "deg"};

// A channel value as an engineer reads it: mm or deg.
double Display(int channel, double si) {
  return channel < 3 ? si * 1e3 : si / kDegree;
}

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
  std::vector<NamedParameter<double>> list = ListParameters(model);
  for (const auto& [name, value] : values) {
    auto it = std::find_if(list.begin(), list.end(),
                           [&](const auto& p) { return p.name == name; });
    if (it == list.end()) {
      return Status::Error("unknown parameter '" + name + "'");
    }
    *it->value = value;
  }
  return Status::Ok();
}

// Measured, model and residual per channel of one experiment, decimated.
Json TimeHistories(const Experiment& e, const std::vector<Vec6<double>>& model,
                   int max_points) {
  const size_t n = e.measured.size();
  const std::vector<size_t> index = Decimation(n, max_points);
  Json t = Json::array(), force = Json::array();
  for (size_t j : index) {
    t.push_back(j * e.sample_period);
  }
  for (int a = 0; a < 3; ++a) {
    Json f = Json::array();
    for (size_t j : index) f.push_back(e.forces[j](a) / 1e3);
    force.push_back(f);
  }
  Json channels = Json::array();
  for (int k = 0; k < 6; ++k) {
    Json measured = Json::array(), predicted = Json::array(),
         residual = Json::array();
    double sum = 0;
    int count = 0;
    for (size_t j = 0; j < n; ++j) {
      if (!e.observed.empty() && !e.observed[j]) continue;
      const double r = e.measured[j](k) - model[j](k);
      sum += r * r;
      ++count;
    }
    for (size_t j : index) {
      measured.push_back(Display(k, e.measured[j](k)));
      predicted.push_back(Display(k, model[j](k)));
      residual.push_back(Display(k, e.measured[j](k) - model[j](k)));
    }
    channels.push_back(
        {{"name", kChannels[k]},
         {"unit", kChannelUnits[k]},
         {"measured", measured},
         {"model", predicted},
         {"residual", residual},
         {"rms", Display(k, count > 0 ? std::sqrt(sum / count) : 0.0)},
         {"sigma", Display(k, e.sigma(k))}});
  }
  return {{"t", t}, {"force_kN", force}, {"channels", channels}};
}

// What the nominal model (bushings from `estimate`) predicts for `e`.
Status Predict(const KcrigConfig& config,
               const std::vector<std::pair<std::string, double>>& estimate,
               const Experiment& e, std::vector<Vec6<double>>* sensed) {
  SuspensionParameters<double> model;
  Status status = ModelWith(config.model, estimate, &model);
  if (!status.ok()) return status;
  EffectModel nominal;
  status = EffectModel::Create(model, {}, 0.1, 10.0, &nominal);
  if (!status.ok()) return status;
  std::vector<double> values;
  for (int i = 0; i < kNumBushings; ++i) {
    values.push_back(model.bushings[i].stiffness);
  }
  return SimulateEffectModel(nominal, values, e, config.experiment.step,
                             sensed);
}

// Runs fn(0 .. count-1) on `threads` threads.
void ParallelFor(int count, int threads, const std::function<void(int)>& fn) {
  std::atomic<int> next{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, threads); ++t) {
    pool.emplace_back([&] {
      for (int i = next++; i < count; i = next++) fn(i);
    });
  }
  for (std::thread& thread : pool) thread.join();
}

struct CampaignData {
  Json doc;
  std::vector<fs::path> iteration_dirs;
  std::vector<std::vector<std::pair<std::string, double>>> estimates;
  std::vector<Design> designs;  // of the experiments run
};

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
    data->estimates.push_back(estimate);
    data->designs.push_back({phi_deg * kDegree, z_a});
  }
  return Status::Ok();
}

// Per-iteration sensitivities and estimates, in the page's units.
Json EstimatesJson(const CampaignData& data) {
  const Json& iterations = data.doc["iterations"];
  Json names = Json::array(), labels = Json::array(), log10 = Json::array(),
       value = Json::array(), low = Json::array(), high = Json::array();
  for (const Json& p : iterations[0]["parameters"]) names.push_back(p["name"]);
  for (const Json& it : iterations) {
    labels.push_back(
        "iteration " + std::to_string(it["iteration"].get<int>()) + " (" +
        std::to_string(it.value("logs", Json::array()).size()) + " log" +
        (it.value("logs", Json::array()).size() == 1 ? "" : "s") + ")");
    Json l = Json::array(), v = Json::array(), lo = Json::array(),
         hi = Json::array();
    for (const Json& p : it["parameters"]) {
      l.push_back(p.value("log10_diag_inv_jtj", Json(nullptr)));
      // Stiffnesses in N/mm.
      const double scale = p.value("unit", "") == "N/m" ? 1e-3 : 1.0;
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
          {"unit", "N/mm"}};
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
  const Interval phi = config.experiment.phi_bounds;
  const Interval z = config.experiment.z_a_bounds;
  const int np = std::max(2, options.surface_phi_points);
  const int nz = std::max(2, options.surface_z_points);
  std::vector<double> d(np * nz), a(np * nz);
  std::vector<Status> failed(np * nz, Status::Ok());
  std::atomic<int> done{0};
  ParallelFor(np * nz, options.num_threads, [&](int job) {
    const int i = job % np, j = job / np;
    const Design design{phi.lower + (phi.upper - phi.lower) * i / (np - 1),
                        z.lower + (z.upper - z.lower) * j / (nz - 1)};
    Eigen::MatrixXd information;
    failed[job] = with_prior->Information(design, false, &information);
    if (!failed[job].ok()) return;
    d[job] = EvaluateCriterion(Criterion::kD, information).value;
    a[job] = EvaluateCriterion(Criterion::kA, information).value;
    if (options.on_progress && (++done % 10 == 0 || done == np * nz)) {
      options.on_progress("criterion surfaces " + std::to_string(done.load()) +
                              "/" + std::to_string(np * nz),
                          static_cast<double>(done) / (np * nz));
    }
  });
  for (const Status& s : failed) {
    if (!s.ok()) return s;
  }
  Json phi_axis = Json::array(), z_axis = Json::array();
  for (int i = 0; i < np; ++i) {
    phi_axis.push_back((phi.lower + (phi.upper - phi.lower) * i / (np - 1)) /
                       kDegree);
  }
  for (int j = 0; j < nz; ++j) {
    z_axis.push_back(z.lower + (z.upper - z.lower) * j / (nz - 1));
  }
  auto grid = [&](const std::vector<double>& v) {
    Json rows = Json::array();
    for (int j = 0; j < nz; ++j) {
      Json row = Json::array();
      for (int i = 0; i < np; ++i) row.push_back(v[j * np + i]);
      rows.push_back(row);
    }
    return rows;
  };
  // The first design's runs go on the surface of their criterion.
  Json design;
  std::string criterion;
  const fs::path design_file = data.iteration_dirs[0] / "design.json";
  if (fs::exists(design_file)) {
    status = ReadJsonFile(design_file, &design);
    if (!status.ok()) return status;
    status = Field(design, "criterion", design_file.string(), &criterion);
    if (!status.ok()) return status;
  }
  *out = Json::array();
  for (const char* name : {"D", "A"}) {
    Json runs = Json::array();
    if (criterion == name) {
      for (const Json& run : design.value("runs", Json::array())) {
        runs.push_back({{"optimizer", run.value("optimizer", "")},
                        {"evaluated", run.value("evaluated", Json::array())},
                        {"path", run.value("path", Json::array())}});
      }
    }
    out->push_back({{"criterion", name},
                    {"phi_deg", phi_axis},
                    {"z_a", z_axis},
                    {"values", grid(std::string(name) == "D" ? d : a)},
                    {"runs", runs}});
  }
  return Status::Ok();
}

// The kriging surrogate refitted to the samples of its first, middle and
// last batch (the refinement of Fig. 2), from the first kriging design run
// of the campaign.
Json KrigingJson(const KcrigConfig& config, const CampaignData& data) {
  for (const fs::path& dir : data.iteration_dirs) {
    Json design;
    if (!fs::exists(dir / "design.json") ||
        !ReadJsonFile(dir / "design.json", &design).ok()) {
      continue;
    }
    for (const Json& run : design.value("runs", Json::array())) {
      if (run.value("optimizer", "") != "kriging") continue;
      const Json& evaluated = run.value("evaluated", Json::array());
      const Interval phi = config.experiment.phi_bounds;
      const Interval z = config.experiment.z_a_bounds;
      std::vector<Eigen::Vector2d> x;
      std::vector<double> y;
      std::vector<int> batch;
      for (const Json& row : evaluated) {
        if (!row.is_array() || row.size() < 4) continue;
        x.emplace_back((row[0].get<double>() * kDegree - phi.lower) /
                           (phi.upper - phi.lower),
                       (row[1].get<double>() - z.lower) / (z.upper - z.lower));
        y.push_back(row[2].get<double>());
        batch.push_back(row[3].get<int>());
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
          points.push_back({evaluated[k][0], evaluated[k][1]});
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
      return {{"criterion", design.value("criterion", "")},
              {"iteration", dir.filename().string()},
              {"panels", panels}};
    }
  }
  return nullptr;
}

// Resolves a log path written in diag.json: as written, else beside it.
fs::path LogPath(const fs::path& diag_file, const std::string& written) {
  if (fs::exists(written)) return written;
  return diag_file.parent_path() / fs::path(written).filename();
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
      for (const char* c : kChannels)
        row.push_back(per.value(c, Json(nullptr)));
      energy.push_back(row);
    }
  }
  result["channels"] = kChannels;
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
  status = LoadExperiment(log.string(), config, &e);
  if (!status.ok()) return status;
  auto simulate = [&](const Json& candidate, std::vector<Vec6<double>>* y) {
    const std::string name = candidate.value("model", "nominal");
    std::vector<std::string> effects;
    if (name != "nominal") {
      std::stringstream list(name);
      for (std::string part; std::getline(list, part, '+');) {
        effects.push_back(part);
      }
    }
    EffectModel model;
    Status made = EffectModel::Create(config.model, effects, 0.1, 10.0, &model);
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

// `text` with every `key` replaced by `value` (the template's slots).
std::string Fill(std::string text, const std::string& key,
                 const std::string& value) {
  const size_t at = text.find(key);
  if (at != std::string::npos) text.replace(at, key.size(), value);
  return text;
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
  std::ifstream plotly_in(options.plotly_js, std::ios::binary);
  if (!plotly_in) {
    return Status::Error(options.plotly_js +
                         ": plotly.js not found (Debian package "
                         "python3-plotly; scripts/setup.sh installs it)");
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
    CampaignData campaign;
    status = ReadCampaign(root, &campaign);
    if (!status.ok()) return status;
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
      status = LoadExperiment(log.string(), config, &e);
      if (!status.ok()) return status;
      std::vector<Vec6<double>> model;
      status = Predict(config, final_estimate, e, &model);
      if (!status.ok())
        return Status::Error(log.string() + ": " + status.message());
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
    status = SurfacesJson(config, campaign, options, &surfaces);
    if (!status.ok()) return status;
    data["surfaces"] = surfaces;
    data["kriging"] = KrigingJson(config, campaign);
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
    progress("diagnosis " + file.string());
    Json d;
    status = DiagnosisJson(config, file, options, &d);
    if (!status.ok()) return status;
    diagnoses.push_back(d);
  }
  data["diagnoses"] = diagnoses;
  summary->diagnosis = !diagnoses.empty();
  Json timings = Json::array();
  for (const fs::path& file : timing_files) {
    Json t;
    status = TimingJson(root, file, &t);
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
  data["expected_figures"] = summary->figures;

  // Inside <script> a "</" would end the element: JSON allows "<\/".
  std::string json = data.dump();
  for (size_t at = json.find("</"); at != std::string::npos;
       at = json.find("</", at + 3)) {
    json.replace(at, 2, "<\\/");
  }
  std::string page = kReportPageTemplate;
  page = Fill(page, "/*KCRIG_PLOTLY*/", plotly.str());
  page = Fill(page, "/*KCRIG_DATA*/", json);
  page = Fill(page, "/*KCRIG_PAGE_SCRIPT*/", kReportPageScript);
  return WriteFilesAtomically({{html_path, page}});
}

}  // namespace kcrig
