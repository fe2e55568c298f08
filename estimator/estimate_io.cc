#include "estimator/estimate_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <limits>

#include "base/json_reader.h"
#include "base/json_writer.h"
#include "nlohmann/json.hpp"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

// A pose in mm and deg, keyed x_mm .. caster_deg.
nlohmann::ordered_json PoseToJson(const Vec6<double>& pose) {
  nlohmann::ordered_json out;
  for (int k = 0; k < kNumChannels; ++k) {
    out[std::string(kChannelNames[k]) + "_" + ChannelDisplayUnit(k)] =
        FiniteOrNull(ChannelDisplayValue(k, pose(k)));
  }
  return out;
}

// est.json's start kinds: where a log's model started (LogInitialState),
// at index dahl_forces + 2 first_row_pose.
struct StartKind {
  const char* name;
  bool dahl_forces, first_row_pose;
};
constexpr StartKind kStartKinds[] = {
    {"equilibrium", false, false},
    {"dahl_forces", true, false},
    {"first_row_pose", false, true},
    {"dahl_forces_and_first_row_pose", true, true}};

const char* StartKindName(const LogInitialState& s) {
  return kStartKinds[!s.dahl_forces.empty() + 2 * s.from_first_row_pose].name;
}

// Per log: where its model started, the tare's mean (and the first row's
// pose where the model started there) in mm and deg, and the Dahl forces
// of a model with hysteresis (LogInitialState).
nlohmann::ordered_json InitialStatesToJson(
    const std::vector<LogInitialState>& states) {
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const LogInitialState& s : states) {
    nlohmann::ordered_json log;
    log["start"] = StartKindName(s);
    log["tare_mean"] = s.tare ? PoseToJson(s.tare->mean) : nullptr;
    if (s.tare && s.from_first_row_pose) {
      log["start_pose"] = PoseToJson(s.tare->at_start);
    }
    if (!s.dahl_forces.empty()) {
      for (size_t i = 0; i < s.dahl_forces.size(); ++i) {
        log["dahl_force_N"][std::string(kBushingChassisNames[i])] =
            FiniteOrNull(s.dahl_forces[i]);
      }
    }
    out.push_back(log);
  }
  return out;
}

// One line per log whose model started from Dahl forces: the rig's
// friction kept from its last run, per bushing [N].
std::string DahlForcesSummary(const std::vector<LogInitialState>& states) {
  std::string out;
  for (size_t k = 0; k < states.size(); ++k) {
    if (states[k].dahl_forces.empty()) continue;
    std::string forces;
    for (size_t i = 0; i < states[k].dahl_forces.size(); ++i) {
      const double force = states[k].dahl_forces[i];
      if (force == 0) continue;  // not hysteretic
      char value[24] = "unknown";
      if (std::isfinite(force)) {
        std::snprintf(value, sizeof(value), "%.0f N", force);
      }
      forces += std::string(forces.empty() ? " " : ", ") +
                std::string(kBushingChassisNames[i]) + " " + value;
    }
    if (forces.empty()) continue;
    out += "  initial state of log " + std::to_string(k + 1) +
           ": Dahl forces kept from its last run:" + forces + "\n";
  }
  return out;
}

nlohmann::ordered_json Matrix(const Eigen::MatrixXd& m) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (int i = 0; i < m.rows(); ++i) {
    nlohmann::ordered_json row = nlohmann::ordered_json::array();
    for (int k = 0; k < m.cols(); ++k) row.push_back(FiniteOrNull(m(i, k)));
    rows.push_back(row);
  }
  return rows;
}

// "    score (1 = noise): x 1.00 ..." per used channel.
std::string ChannelScores(const Adequacy& a) {
  std::string out = "    score per channel (1 = noise):";
  char item[48];
  for (int k = 0; k < 6; ++k) {
    if (!a.channels[k].used) continue;
    std::snprintf(item, sizeof(item), " %s %.3g", kChannelNames[k],
                  a.channels[k].score);
    out += item;
  }
  return out + "\n";
}

}  // namespace

std::string IntervalWideningSummary(const EstimationResult& result) {
  if (!(result.interval_widening > kReportedWidening)) return "";
  char line[320];
  std::snprintf(line, sizeof(line),
                "  intervals widened up to %.1fx: the fit's gradient varies "
                "more over blocks of each log than independent samples at "
                "the sensor noise allow (a residual correlated in time or "
                "uneven across channels)\n",
                result.interval_widening);
  return line;
}

double DisplayScale(const ParameterEstimate& p) {
  return p.unit == "N/m" ? 1e-3 : 1.0;
}

std::string DisplayUnit(const ParameterEstimate& p) {
  return p.unit == "N/m" ? "N/mm" : p.unit;
}

std::string AdequacyToJson(const Adequacy& a) {
  nlohmann::ordered_json doc;
  doc["verdict"] = a.adequate ? "adequate" : "inadequate";
  doc["reason"] = a.reason;
  doc["chi2"] = FiniteOrNull(a.chi_square);
  doc["dof"] = FiniteOrNull(a.dof);
  doc["chi2_p"] = FiniteOrNull(a.p_value);
  doc["score"] = FiniteOrNull(a.score);
  doc["ljung_box_p"] = FiniteOrNull(a.whiteness_p);
  doc["discretisation_rms_sigma"] = FiniteOrNull(a.discretisation);
  doc["judged"] = a.continuous_limit ? "continuous_limit" : "model_step";
  nlohmann::ordered_json channels;
  for (int k = 0; k < 6; ++k) {
    const ChannelAdequacy& c = a.channels[k];
    if (!c.used) continue;
    channels[kChannelNames[k]] = {
        {"score", FiniteOrNull(c.score)},
        {"ljung_box_p", FiniteOrNull(c.whiteness_p)},
        {"discretisation_rms_sigma", FiniteOrNull(c.discretisation)},
        {"samples", c.samples}};
  }
  doc["channels"] = channels;
  return doc.dump();
}

std::string AdequacyLine(const Adequacy& a) {
  char discretisation[120] = "";
  if (a.discretisation > 0) {
    std::snprintf(discretisation, sizeof(discretisation),
                  "; the model's discretisation error %.2f sigma RMS at most%s",
                  a.discretisation, a.continuous_limit ? ", set apart" : "");
  }
  if (!a.adequate) return "INADEQUATE: " + a.reason + discretisation;
  char line[200];
  std::snprintf(line, sizeof(line),
                "adequate: chi2/dof %.3f (p %.2g), residual white (Ljung-Box "
                "p %.2g)",
                a.dof > 0 ? a.chi_square / a.dof : 0.0, a.p_value,
                a.whiteness_p);
  return line + std::string(discretisation);
}

std::string InadequacyWarning(const std::vector<std::string>& logs) {
  std::string command = "kcrig diagnose";
  for (const std::string& log : logs) command += " --log " + log;
  return "  the model does not explain these logs: the intervals above assume "
         "a correct model and are not to be trusted; find the unmodelled "
         "effect with: " +
         command + "\n";
}

std::string EstimationResultToJson(
    const EstimationResult& result, const std::vector<std::string>& logs,
    const std::vector<ParameterProfile>& profiles,
    const HoldoutPrediction& holdout) {
  nlohmann::ordered_json doc;
  doc["format"] = "kcrig estimate 1";
  doc["logs"] = logs;
  doc["parameters"] = ParameterEstimatesToJson(result.parameters);
  doc["covariance"] = Matrix(result.covariance);
  doc["correlation"] = Matrix(result.correlation);
  doc["information_matrix"] = Matrix(result.information);
  std::vector<double> singular(
      result.singular_values.data(),
      result.singular_values.data() + result.singular_values.size());
  doc["singular_values"] = singular;
  doc["condition_number"] = FiniteOrNull(result.condition_number);
  doc["rank"] = result.rank;
  doc["ill_conditioned"] = result.ill_conditioned;
  doc["unidentifiable_combinations"] = result.unidentifiable_combinations;
  doc["dependent_parameters"] = result.dependent_parameters;
  nlohmann::ordered_json rms;
  for (int k = 0; k < 6; ++k) {
    rms[kChannelNames[k]] =
        result.channel_used[k] ? FiniteOrNull(result.residual_rms(k)) : nullptr;
  }
  doc["residual_rms"] = rms;
  doc["residual_rms_units"] = "m for x, y, z; rad for toe, camber, caster";
  doc["num_residuals"] = result.num_residuals;
  doc["rig_memory_rows"] = result.memory_rows;
  doc["rig_initial_state"] = InitialStatesToJson(result.initial_states);
  doc["cost"] = result.cost;
  doc["sigma_hat"] = result.sigma_hat;
  doc["residual_correlation"] = FiniteOrNull(result.residual_correlation);
  doc["interval_widening"] = FiniteOrNull(result.interval_widening);
  doc["iterations"] = result.iterations;
  doc["integrator_step_s"] = result.integrator_step > 0
                                 ? FiniteOrNull(result.integrator_step)
                                 : nlohmann::ordered_json();
  doc["converged"] = result.converged;
  doc["termination"] = result.termination;
  doc["adequacy"] =
      nlohmann::ordered_json::parse(AdequacyToJson(result.adequacy));
  if (!holdout.logs.empty()) {
    doc["prediction"] = {{"logs", holdout.logs},
                         {"adequacy", nlohmann::ordered_json::parse(
                                          AdequacyToJson(holdout.adequacy))}};
  }
  if (!profiles.empty()) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const ParameterProfile& p : profiles) {
      nlohmann::ordered_json delta = nlohmann::ordered_json::array();
      for (double d : p.delta_chi2) delta.push_back(FiniteOrNull(d));
      list.push_back(
          {{"name", p.name},
           {"identifiability", IdentifiabilityName(p.identifiability)},
           {"ci95_profile", {FiniteOrNull(p.lower), FiniteOrNull(p.upper)}},
           {"values", p.values},
           {"delta_chi2", delta}});
    }
    doc["profiles"] = list;
  }
  return doc.dump(2) + "\n";
}

namespace {

// The fit's one line, the rows left out, the Dahl forces, the widening.
std::string FitHeader(const EstimationResult& result) {
  std::string out;
  char line[256];
  std::snprintf(line, sizeof(line),
                "kcrig estimate: %d residuals, %zu parameters, %s after %d "
                "iterations (%.2f s); sigma_hat %.3f\n",
                result.num_residuals, result.parameters.size(),
                result.converged ? "converged" : "NOT converged",
                result.iterations, result.seconds, result.sigma_hat);
  out += line;
  if (std::any_of(result.memory_rows.begin(), result.memory_rows.end(),
                  [](int rows) { return rows > 0; })) {
    std::string rows;
    for (int r : result.memory_rows) {
      rows += (rows.empty() ? "" : ", ") + std::to_string(r);
    }
    out += "  left out: the tare and lead-in rows of each rig log (" + rows +
           "), which start from the rig's memory of its last run\n";
  }
  out += DahlForcesSummary(result.initial_states);
  out += IntervalWideningSummary(result);
  return out;
}

// The estimates with their 95 % half-widths and the bars of the paper's
// Fig. 4: log10 diag((J^T J)^-1), from the smallest to each value.
std::string EstimateTable(const EstimationResult& result) {
  std::string out;
  char line[256];
  std::snprintf(line, sizeof(line), "  %-10s %14s %12s %-6s  %s\n", "parameter",
                "estimate", "+- 95 %", "", "log10 diag((J^T J)^-1)");
  out += line;
  double low = 0, high = 0;
  bool any = false;
  for (const ParameterEstimate& p : result.parameters) {
    if (!std::isfinite(p.log10_inverse_information)) continue;
    low = any ? std::min(low, p.log10_inverse_information)
              : p.log10_inverse_information;
    high = any ? std::max(high, p.log10_inverse_information)
               : p.log10_inverse_information;
    any = true;
  }
  low = std::floor(low) - 0.5;
  high = std::max(high, low + 1.0);
  for (const ParameterEstimate& p : result.parameters) {
    const double scale = DisplayScale(p);
    std::string bar;
    if (std::isfinite(p.log10_inverse_information)) {
      const int width = static_cast<int>(std::lround(
          30.0 * (p.log10_inverse_information - low) / (high - low)));
      bar = std::string(width, '#');
      std::snprintf(
          line, sizeof(line), "  %-10s %14.3f %12.3f %-6s  %-30s %6.2f\n",
          p.name.c_str(), p.value * scale, (p.ci95_high - p.value) * scale,
          DisplayUnit(p).c_str(), bar.c_str(), p.log10_inverse_information);
    } else {
      std::snprintf(line, sizeof(line), "  %-10s %14.3f %12s %-6s  %s\n",
                    p.name.c_str(), p.value * scale, "n/a",
                    DisplayUnit(p).c_str(), "not identifiable");
    }
    out += line;
  }
  return out;
}

// What the data do not determine: bounds, combinations, conditioning.
std::string IdentifiabilityWarnings(const EstimationResult& result) {
  std::string out;
  char line[256];
  for (const ParameterEstimate& p : result.parameters) {
    if (p.at_bound)
      out += "  " + p.name +
             " ended on its bound: the box, not the data, set it\n";
  }
  for (const std::string& combination : result.unidentifiable_combinations) {
    out += "  not identifiable from these data: " + combination + "\n";
  }
  if (result.ill_conditioned) {
    std::snprintf(line, sizeof(line),
                  "  ill-conditioned: condition number of J %.3g\n",
                  result.condition_number);
    out += line;
  }
  return out;
}

std::string ProfileLines(const std::vector<ParameterProfile>& profiles) {
  std::string out;
  char line[256];
  for (const ParameterProfile& p : profiles) {
    std::snprintf(line, sizeof(line), "  profile %-8s %s", p.name.c_str(),
                  IdentifiabilityName(p.identifiability));
    out += line;
    if (std::isfinite(p.lower) && std::isfinite(p.upper)) {
      const double scale = p.name.rfind("c_", 0) == 0 ? 1e-3 : 1.0;
      std::snprintf(line, sizeof(line), ", 95 %% profile interval [%.3f, %.3f]",
                    p.lower * scale, p.upper * scale);
      out += line;
    }
    out += "\n";
  }
  return out;
}

// The residual and the adequacy of the fit and of the hold-out's
// prediction, with what to run when the hold-out is mispredicted.
std::string AdequacyLines(const EstimationResult& result,
                          const std::vector<std::string>& logs,
                          const HoldoutPrediction& holdout) {
  std::string out;
  char line[256];
  out += "  residual RMS:";
  for (int k = 0; k < 6; ++k) {
    if (!result.channel_used[k]) continue;
    std::snprintf(line, sizeof(line), " %s %.4f %s", kChannelNames[k],
                  ChannelDisplayValue(k, result.residual_rms(k)),
                  ChannelDisplayUnit(k));
    out += line;
  }
  out += "\n";
  out += "  model " + AdequacyLine(result.adequacy) + "\n";
  out += ChannelScores(result.adequacy);
  if (!holdout.logs.empty()) {
    out += "  hold-out prediction " + AdequacyLine(holdout.adequacy) + "\n";
    out += ChannelScores(holdout.adequacy);
  }
  if (!result.adequacy.adequate) out += InadequacyWarning(logs);
  if (result.adequacy.adequate && !holdout.adequacy.adequate &&
      !holdout.logs.empty()) {
    std::string command = "kcrig diagnose";
    for (const std::string& log : logs) command += " --log " + log;
    for (const std::string& log : holdout.logs) command += " --holdout " + log;
    out +=
        "  the fit explains its logs but mispredicts the hold-out: an "
        "effect absorbed by biased parameters; the intervals are not to be "
        "trusted; find it with: " +
        command + "\n";
  }
  return out;
}

}  // namespace

std::string EstimationSummary(const EstimationResult& result,
                              const std::vector<std::string>& logs,
                              const std::vector<ParameterProfile>& profiles,
                              const HoldoutPrediction& holdout) {
  return FitHeader(result) + EstimateTable(result) +
         IdentifiabilityWarnings(result) + ProfileLines(profiles) +
         AdequacyLines(result, logs, holdout);
}

namespace {

// A pose written by PoseToJson back in SI; null entries read as NaN.
Status ReadPose(const nlohmann::json& pose, const std::string& field,
                Vec6<double>* out) {
  if (!pose.is_object()) return Status::Error(field + ": expected an object");
  for (int k = 0; k < kNumChannels; ++k) {
    const std::string key =
        std::string(kChannelNames[k]) + "_" + ChannelDisplayUnit(k);
    const auto value = pose.find(key);
    if (value == pose.end() || !(value->is_number() || value->is_null())) {
      return Status::Error(field + "." + key + ": missing or not a number");
    }
    (*out)(k) = value->is_null()
                    ? std::numeric_limits<double>::quiet_NaN()
                    : value->get<double>() / ChannelDisplayValue(k, 1.0);
  }
  return Status::Ok();
}

// One entry of rig_initial_state (InitialStatesToJson) back. A tare's
// first-row pose that est.json does not give (the model did not start
// there) reads as NaN.
Status ReadInitialState(const nlohmann::json& log, const std::string& field,
                        LogInitialState* state) {
  const std::string start =
      log.is_object() && log.contains("start") && log["start"].is_string()
          ? log["start"].get<std::string>()
          : "";
  const StartKind* kind =
      std::find_if(std::begin(kStartKinds), std::end(kStartKinds),
                   [&start](const StartKind& k) { return start == k.name; });
  if (kind == std::end(kStartKinds)) {
    return Status::Error(field +
                         ".start: expected equilibrium, dahl_forces, "
                         "first_row_pose or dahl_forces_and_first_row_pose");
  }
  state->from_first_row_pose = kind->first_row_pose;
  if (log.contains("tare_mean") && !log["tare_mean"].is_null()) {
    TarePose tare;
    KCRIG_RETURN_IF_ERROR(
        ReadPose(log["tare_mean"], field + ".tare_mean", &tare.mean));
    tare.at_start.setConstant(std::numeric_limits<double>::quiet_NaN());
    if (kind->first_row_pose) {
      KCRIG_RETURN_IF_ERROR(ReadPose(log.value("start_pose", nlohmann::json()),
                                     field + ".start_pose", &tare.at_start));
    }
    state->tare = tare;
  }
  if (!kind->dahl_forces) return Status::Ok();
  const nlohmann::json forces = log.value("dahl_force_N", nlohmann::json());
  for (const std::string_view name : kBushingChassisNames) {
    const std::string bushing(name);
    const std::string key = field + ".dahl_force_N." + bushing;
    if (!forces.is_object() || !forces.contains(bushing)) {
      return Status::Error(key + ": missing");
    }
    const nlohmann::json& f = forces[bushing];
    if (!f.is_number() && !f.is_null()) {
      return Status::Error(key + ": not a number");
    }
    state->dahl_forces.push_back(f.is_null()
                                     ? std::numeric_limits<double>::quiet_NaN()
                                     : f.get<double>());
  }
  return Status::Ok();
}

// est.json's logs and rig_initial_state, when it has them.
Status ReadLogsAndInitialStates(const nlohmann::json& doc,
                                EstimateFile* estimate) {
  if (doc.contains("logs")) {
    if (!doc["logs"].is_array()) return Status::Error("logs: not a list");
    for (const nlohmann::json& log : doc["logs"]) {
      if (!log.is_string()) return Status::Error("logs: not a list of paths");
      estimate->logs.push_back(log.get<std::string>());
    }
  }
  if (!doc.contains("rig_initial_state")) return Status::Ok();
  const nlohmann::json& states = doc["rig_initial_state"];
  if (!states.is_array()) {
    return Status::Error("rig_initial_state: not a list");
  }
  for (size_t i = 0; i < states.size(); ++i) {
    LogInitialState state;
    KCRIG_RETURN_IF_ERROR(ReadInitialState(
        states[i], "rig_initial_state[" + std::to_string(i) + "]", &state));
    estimate->initial_states.push_back(std::move(state));
  }
  return Status::Ok();
}

}  // namespace

nlohmann::ordered_json ParameterEstimateToJson(const ParameterEstimate& p) {
  return {{"name", p.name},
          {"unit", p.unit},
          {"nominal", FiniteOrNull(p.nominal)},
          {"initial", FiniteOrNull(p.initial)},
          {"value", FiniteOrNull(p.value)},
          {"standard_error", FiniteOrNull(p.standard_error)},
          {"ci95", {FiniteOrNull(p.ci95_low), FiniteOrNull(p.ci95_high)}},
          {"discretisation_bias", FiniteOrNull(p.discretisation_bias)},
          {"log10_diag_inv_jtj", FiniteOrNull(p.log10_inverse_information)},
          {"identifiable", p.identifiable},
          {"at_bound", p.at_bound}};
}

nlohmann::ordered_json ParameterEstimatesToJson(
    const std::vector<ParameterEstimate>& all, size_t begin, size_t end) {
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (size_t i = begin; i < std::min(end, all.size()); ++i) {
    list.push_back(ParameterEstimateToJson(all[i]));
  }
  return list;
}

Status ReadParameterEstimate(const nlohmann::json& node,
                             const std::string& where, ParameterEstimate* p) {
  *p = ParameterEstimate();
  KCRIG_RETURN_IF_ERROR(ReadField(node, "name", where, &p->name));
  KCRIG_RETURN_IF_ERROR(ReadField(node, "value", where, &p->value));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // A field of another type reads as not given, as a missing one does.
  auto field = [&node](const char* key) {
    return node.contains(key) ? node[key] : nlohmann::json();
  };
  auto number = [&](const char* key) {
    const nlohmann::json value = field(key);
    return value.is_number() ? value.get<double>() : nan;
  };
  auto flag = [&](const char* key, bool otherwise) {
    const nlohmann::json value = field(key);
    return value.is_boolean() ? value.get<bool>() : otherwise;
  };
  const nlohmann::json unit = field("unit");
  p->unit = unit.is_string() ? unit.get<std::string>() : "";
  p->nominal = number("nominal");
  p->initial = number("initial");
  p->standard_error = number("standard_error");
  const nlohmann::json ci95 = field("ci95");
  const bool interval = ci95.is_array() && ci95.size() == 2 &&
                        ci95[0].is_number() && ci95[1].is_number();
  p->ci95_low = interval ? ci95[0].get<double>() : nan;
  p->ci95_high = interval ? ci95[1].get<double>() : nan;
  const double bias = number("discretisation_bias");
  p->discretisation_bias = std::isfinite(bias) ? bias : 0.0;
  p->log10_inverse_information = number("log10_diag_inv_jtj");
  p->identifiable = flag("identifiable", interval);
  p->at_bound = flag("at_bound", false);
  return Status::Ok();
}

Status ReadEstimateFile(const std::string& path, EstimateFile* estimate) {
  nlohmann::json doc;
  KCRIG_RETURN_IF_ERROR(ReadJsonFile(path, &doc));
  auto error = [&path](const std::string& field, const std::string& what) {
    return Status::Error(path + ": " + field + ": " + what);
  };
  if (!doc.is_object() || doc.value("format", "") != "kcrig estimate 1") {
    return error("format",
                 "not a kcrig est.json (expected \"kcrig estimate 1\")");
  }
  if (!doc.contains("parameters") || !doc["parameters"].is_array() ||
      doc["parameters"].empty()) {
    return error("parameters", "missing or empty");
  }
  *estimate = EstimateFile();
  for (size_t i = 0; i < doc["parameters"].size(); ++i) {
    ParameterEstimate p;
    KCRIG_RETURN_IF_ERROR(ReadParameterEstimate(
        doc["parameters"][i], path + ": parameters[" + std::to_string(i) + "]",
        &p));
    estimate->names.push_back(p.name);
    estimate->values.push_back(p.value);
  }
  const int n = static_cast<int>(estimate->names.size());
  // An n x n matrix of numbers, when the file has `field`; with
  // `allow_null`, null (written for a non-finite entry) reads as NaN.
  auto read_matrix = [&](const std::string& field, bool allow_null,
                         Eigen::MatrixXd* out) {
    if (!doc.contains(field)) return Status::Ok();
    const nlohmann::json& m = doc[field];
    if (!m.is_array() || static_cast<int>(m.size()) != n) {
      return error(field, "expected " + std::to_string(n) + " rows");
    }
    out->resize(n, n);
    for (int r = 0; r < n; ++r) {
      if (!m[r].is_array() || static_cast<int>(m[r].size()) != n) {
        return error(field,
                     "expected " + std::to_string(n) + " columns in every row");
      }
      for (int c = 0; c < n; ++c) {
        if (allow_null && m[r][c].is_null()) {
          (*out)(r, c) = std::numeric_limits<double>::quiet_NaN();
        } else if (m[r][c].is_number()) {
          (*out)(r, c) = m[r][c].get<double>();
        } else {
          return error(field, "non-numeric entry");
        }
      }
    }
    return Status::Ok();
  };
  KCRIG_RETURN_IF_ERROR(
      read_matrix("information_matrix", false, &estimate->information));
  KCRIG_RETURN_IF_ERROR(read_matrix("covariance", true, &estimate->covariance));
  if (doc.contains("integrator_step_s") &&
      !doc["integrator_step_s"].is_null()) {
    const nlohmann::json& step = doc["integrator_step_s"];
    if (!step.is_number() ||
        !(step.get<double>() > 0 && step.get<double>() <= 1)) {
      return error("integrator_step_s", "must be a number within (0, 1] s");
    }
    estimate->integrator_step = step.get<double>();
  }
  const Status states = ReadLogsAndInitialStates(doc, estimate);
  return states.ok() ? states : Status::Error(path + ": " + states.message());
}

}  // namespace kcrig
